"""Reading scene graphs back: round trips, and every kind of bad document."""

from __future__ import annotations

import json
import socket
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from rdflib import Graph
from rdflib.compare import isomorphic

from graph_store import (
    Entity,
    RDFFormatError,
    Relation,
    SceneGraph,
    SceneMeta,
)
from graph_store.rdf import read_scenes, serialize_scenes, to_rdflib_graph
from tests.strategies import random_scene, scene_graphs

pytestmark = pytest.mark.filterwarnings("ignore:ConjunctiveGraph is deprecated")

FORMATS = ("turtle", "ntriples", "jsonld")
RDFLIB_FORMAT = {"turtle": "turtle", "ntriples": "nt", "jsonld": "json-ld"}
E = "https://w3id.org/causalsplat/scene/s/entity/"


@settings(max_examples=40, deadline=None)
@given(scene_graphs(), st.sampled_from(FORMATS), st.sampled_from(["oxigraph", "rdflib"]))
def test_export_import_gives_the_same_graph(g: SceneGraph, fmt: str, engine: str) -> None:
    assert read_scenes(serialize_scenes(g, fmt), fmt, engine=engine) == [g]


@settings(max_examples=25, deadline=None)
@given(scene_graphs(), st.sampled_from(FORMATS))
def test_export_import_export_is_isomorphic(g: SceneGraph, fmt: str) -> None:
    first = serialize_scenes(g, fmt)
    again = serialize_scenes(read_scenes(first, fmt), fmt)
    parse = RDFLIB_FORMAT[fmt]
    assert isomorphic(
        Graph().parse(data=first, format=parse), Graph().parse(data=again, format=parse)
    )


@settings(max_examples=15, deadline=None)
@given(
    st.lists(scene_graphs(max_entities=6), min_size=2, max_size=4, unique_by=lambda g: g.scene_id),
    st.sampled_from(FORMATS),
)
def test_several_scenes_come_back_sorted_by_id(graphs: list[SceneGraph], fmt: str) -> None:
    back = read_scenes(serialize_scenes(graphs, fmt), fmt)
    assert back == sorted(graphs, key=lambda g: g.scene_id)


@pytest.mark.parametrize("fmt", FORMATS)
def test_many_entities_round_trip(fmt: str) -> None:
    g = random_scene("big", 1500, 6000, seed=3)
    assert read_scenes(serialize_scenes(g, fmt), fmt) == [g]


def test_without_evidence_relations_come_back_with_empty_evidence() -> None:
    g = random_scene("s", 30, 80, seed=1)
    (back,) = read_scenes(serialize_scenes(g, "turtle", evidence=False))
    assert back.relations == tuple(Relation(r.src, r.dst, r.type) for r in g.relations)
    assert back.entities == g.entities


def test_sources_paths_bytes_and_suffixes(tmp_path: Path) -> None:
    g = random_scene("s", 5, 6, seed=2)
    for suffix, fmt in ((".ttl", "turtle"), (".nt", "ntriples"), (".jsonld", "jsonld"),
                        (".json", "jsonld")):  # fmt: skip
        path = tmp_path / f"scene{suffix}"
        path.write_text(serialize_scenes(g, fmt), encoding="utf-8")
        assert read_scenes(path) == [g]
        assert read_scenes(str(path)) == [g]
        assert read_scenes(path.read_bytes(), fmt) == [g]
    assert read_scenes(serialize_scenes(g, "jsonld").encode()) == [g]  # sniffed
    assert read_scenes(serialize_scenes(g, "ntriples")) == [g]  # N-Triples is Turtle
    assert read_scenes("") == []
    odd = tmp_path / "scene.rdf"
    odd.write_text(serialize_scenes(g, "turtle"), encoding="utf-8")
    with pytest.raises(RDFFormatError, match="suffix"):
        read_scenes(odd)
    assert read_scenes(odd, "turtle") == [g]
    with pytest.raises(RDFFormatError, match="cannot read"):
        read_scenes(tmp_path / "missing.ttl")


PREFIXES = """@prefix csg: <https://w3id.org/causalsplat/ns#> .
@prefix xsd: <http://www.w3.org/2001/XMLSchema#> .
<https://w3id.org/causalsplat/scene/s> a csg:Scene ; csg:sceneId "s" .
"""


def entity_ttl(local_id: int = 1, **overrides: str | None) -> str:
    props = {
        "csg:inScene": "<https://w3id.org/causalsplat/scene/s>",
        "csg:localId": str(local_id),
        "csg:category": '"cup"',
        **{f"csg:{a}{x}": '"0.5"^^xsd:double' for a in ("centroid", "min", "max") for x in "XYZ"},
    }
    for key, value in overrides.items():
        if value is None:
            props.pop(f"csg:{key}")
        else:
            props[f"csg:{key}"] = value
    body = " ;\n  ".join(f"{k} {v}" for k, v in props.items())
    return f"<{E}{local_id}> a csg:Entity ;\n  {body} .\n"


def test_a_hand_written_minimal_document_reads() -> None:
    (g,) = read_scenes(PREFIXES + entity_ttl(1) + entity_ttl(2) + f"<{E}1> csg:above <{E}2> .")
    assert g.meta == SceneMeta("s")
    assert g.entities[0] == Entity(1, "cup", (0.5,) * 3, (0.5,) * 3, (0.5,) * 3)
    assert g.relations == (Relation(1, 2, "above"),)


P = PREFIXES
T_SCENE = PREFIXES.replace("scene/s>", "scene/t>").replace('"s"', '"t"')
ATTR = '<http://a> csg:key "k" ; csg:value "v" ; csg:attributeSource "guess" .'
NO_SCENE_ID = "@prefix csg: <https://w3id.org/causalsplat/ns#> .\n<http://s> a csg:Scene ."
BAD_DOCUMENTS = [
    ("malformed", P + "<a> <b> .", "malformed turtle"),
    ("no category", P + entity_ttl(category=None),
     f"entity <{E}1>: missing required property csg:category"),
    ("two categories", P + entity_ttl(category='"a", "b"'), "csg:category has 2 values"),
    ("string coordinate", P + entity_ttl(centroidX='"abc"'), "csg:centroidX must be a number"),
    ("bad double", P + entity_ttl(centroidX='"abc"^^xsd:double'),
     "csg:centroidX must be a number"),
    ("NaN", P + entity_ttl(centroidY='"NaN"^^xsd:double'), "csg:centroidY must be a finite"),
    ("INF", P + entity_ttl(maxZ='"INF"^^xsd:double'), "csg:maxZ must be a finite number"),
    ("float id", P + entity_ttl(localId="1.5"), "csg:localId must be an integer"),
    ("string id", P + entity_ttl(localId='"1"'), "csg:localId must be an integer"),
    ("iri category", P + entity_ttl(category="<http://x/>"), "csg:category must be a plain"),
    ("lang category", P + entity_ttl(category='"cup"@en'), "language-tagged"),
    ("negative count", P + entity_ttl(pointCount="-3"), "point_count of entity 1 must be >= 0"),
    ("bad bbox", P + entity_ttl(minX='"2.0"^^xsd:double'), "entity 1 has min x=2.0 > max x=0.5"),
    ("no such scene", T_SCENE + entity_ttl(),
     "csg:inScene <https://w3id.org/causalsplat/scene/s> is not a csg:Scene"),
    ("unknown predicate", P + entity_ttl() + f"<{E}1> csg:on_top_of <{E}1> .",
     "unknown predicate csg:on_top_of"),
    ("unknown class", P + "<http://x/a> a csg:Thing .", "unknown class csg:Thing"),
    ("view-dependent", P + entity_ttl(1) + entity_ttl(2) + f"<{E}1> csg:left_of <{E}2> .",
     "csg:left_of is view-dependent"),
    ("dangling relation", P + entity_ttl(1) + f"<{E}1> csg:near <{E}9> .",
     f"csg:near <{E}9> is not a csg:Entity"),
    ("self relation", P + entity_ttl(1) + f"<{E}1> csg:near <{E}1> .", "relates an entity to"),
    ("duplicate ids", P + entity_ttl(1) + entity_ttl(2, localId="1"), "duplicate entity id 1"),
    ("no scene id", NO_SCENE_ID, "missing required property csg:sceneId"),
    ("entity of no scene", P + entity_ttl(inScene="<http://elsewhere/>"), "is not a csg:Scene"),
    ("bad up axis", P + '<https://w3id.org/causalsplat/scene/s> csg:upAxis "w" .', "up axis"),
    ("bad attribute source", P + entity_ttl(hasAttribute="<http://a>") + ATTR,
     "unknown attribute source 'guess'"),
]  # fmt: skip


@pytest.mark.parametrize(
    ("name", "doc", "message"), BAD_DOCUMENTS, ids=[b[0] for b in BAD_DOCUMENTS]
)
@pytest.mark.parametrize("engine", ["oxigraph", "rdflib"])
def test_bad_documents_raise_rdf_format_error(
    name: str, doc: str, message: str, engine: str
) -> None:
    with pytest.raises(RDFFormatError) as info:
        read_scenes(doc, "turtle", engine=engine)
    assert message in str(info.value)


def test_errors_name_the_scene() -> None:
    doc = PREFIXES + entity_ttl(centroidZ='"NaN"^^xsd:double')
    with pytest.raises(RDFFormatError, match=r"scene 's', entity <.*/entity/1>: csg:centroidZ"):
        read_scenes(doc)


def test_assertions_must_match_a_relation() -> None:
    g = SceneGraph(
        SceneMeta("s"),
        tuple(Entity(i, "a", (0, 0, 0), (0, 0, 0), (0, 0, 0)) for i in (1, 2)),
        (Relation(1, 2, "above", {"distance": 1.0}),),
    )
    text = serialize_scenes(g, "ntriples")
    direct = f"<{E}1> <https://w3id.org/causalsplat/ns#above> <{E}2> .\n"
    assert direct in text
    with pytest.raises(RDFFormatError, match="no matching triple"):
        read_scenes(text.replace(direct, ""), "ntriples")
    bad_value = text.replace('"1.0"^^<http://www.w3.org/2001/XMLSchema#double>', '"x"')
    with pytest.raises(RDFFormatError, match=r"evidence .* csg:value must be a number"):
        read_scenes(bad_value, "ntriples")


def test_jsonld_remote_contexts_are_never_fetched() -> None:
    with socket.socket() as server:
        server.bind(("127.0.0.1", 0))
        server.listen(1)
        server.setblocking(False)
        port = server.getsockname()[1]
        doc = json.dumps({"@context": f"http://127.0.0.1:{port}/ctx.jsonld", "@id": "http://a"})
        for engine in ("oxigraph", "rdflib"):
            with pytest.raises(RDFFormatError):
                read_scenes(doc.encode(), "jsonld", engine=engine)
        with pytest.raises(BlockingIOError):
            server.accept()


def test_jsonld_round_trip_through_rdflib_graph() -> None:
    g = random_scene("s", 10, 20, seed=4)
    doc = serialize_scenes(g, "jsonld")
    assert json.loads(doc)
    assert isomorphic(Graph().parse(data=doc, format="json-ld"), to_rdflib_graph(g))
