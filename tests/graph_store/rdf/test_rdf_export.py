"""The streaming Turtle / N-Triples writers against rdflib, and the fixed RDF mapping."""

from __future__ import annotations

import io
import re

import pyoxigraph as ox
import pytest
import rdflib
from hypothesis import given, settings
from rdflib import RDF, RDFS, Graph, Literal, URIRef
from rdflib.compare import isomorphic

from graph_store import (
    Attribute,
    Entity,
    InvalidSceneError,
    MaskRecord,
    RDFFormatError,
    Relation,
    SceneGraph,
    SceneMeta,
    View,
)
from graph_store.rdf import (
    BOT,
    CSG,
    GEO,
    entity_iri,
    scene_iri,
    serialize_scenes,
    to_rdflib_graph,
    write_scenes,
)
from tests.strategies import scene_graphs

RDFLIB_FORMAT = {"turtle": "turtle", "ntriples": "nt", "jsonld": "json-ld"}
OX_FORMAT = {"turtle": ox.RdfFormat.TURTLE, "ntriples": ox.RdfFormat.N_TRIPLES}
pytestmark = pytest.mark.filterwarnings("ignore:ConjunctiveGraph is deprecated")

HOSTILE = [
    'quote " and \\ backslash',
    "line\nfeed\rreturn\ttab",
    "\x01\x02\x1f\x7f control",
    "unicode é ü 漢字 😀 \u0085 \u2028 \u2029 \ufeff \uffff",
    '"""triple quotes""" \'\'\'',
    "> <http://evil/> . } ; DROP ALL #",
    "",
    " ",
    "%41%2F/?#[]@!$&'()*+,;=",
]


def hostile_scene() -> SceneGraph:
    ents = []
    for i, text in enumerate(HOSTILE):
        ents.append(
            Entity(
                id=i,
                category=text or "empty",
                centroid=(i * 0.1, -0.0, 5e-324),
                bbox_min=(-1.7976931348623157e308, -1.0, -1e-300),
                bbox_max=(1.7976931348623157e308, 1.0, 1e-300),
                external_id=f"{i}{text}",
                caption=text,
                confidence=1 / 3,
                attributes=(
                    Attribute(text or "k", text or "v"),
                    Attribute("colour/ü", text + "!", "vlm"),
                ),
            )
        )
    rels = [
        Relation(0, 1, "above", {HOSTILE[0]: 0.1, "distance": 1e-17}),
        Relation(1, 0, "below", {HOSTILE[4]: -2.5}),
        Relation(2, 3, "near"),
    ]
    return SceneGraph(
        SceneMeta(
            'scene "1"/\\ü\n',
            name=HOSTILE[1],
            config_hash="deadbeef",
            provenance={HOSTILE[2]: HOSTILE[3], "file": HOSTILE[5]},
        ),
        tuple(ents),
        tuple(rels),
        (View(0, HOSTILE[3], 640, 480),),
        (MaskRecord(0, 0, 1, HOSTILE[0], 0.25), MaskRecord(0, 1)),
    )


def _parse(text: str, fmt: str) -> Graph:
    return Graph().parse(data=text, format=RDFLIB_FORMAT[fmt])


@pytest.mark.parametrize("fmt", ["turtle", "ntriples", "jsonld"])
@pytest.mark.parametrize("evidence", [True, False])
def test_hostile_strings_round_trip_through_rdflib(fmt: str, evidence: bool) -> None:
    g = hostile_scene()
    text = serialize_scenes(g, fmt, evidence=evidence)
    assert isomorphic(_parse(text, fmt), to_rdflib_graph(g, evidence=evidence))


@pytest.mark.parametrize("fmt", ["turtle", "ntriples"])
def test_fast_writers_parse_with_oxigraph_strictly(fmt: str) -> None:
    g = hostile_scene()
    text = serialize_scenes(g, fmt)
    quads = list(ox.parse(text.encode(), format=OX_FORMAT[fmt]))
    assert len(quads) == len(to_rdflib_graph(g))


@settings(max_examples=60, deadline=None)
@given(scene_graphs())
def test_fast_writers_are_isomorphic_to_rdflib(g: SceneGraph) -> None:
    reference = to_rdflib_graph(g)
    for fmt in ("turtle", "ntriples"):
        parsed = _parse(serialize_scenes(g, fmt), fmt)
        assert isomorphic(parsed, reference), fmt


@settings(max_examples=20, deadline=None)
@given(scene_graphs(max_entities=5, scene_id="a"), scene_graphs(max_entities=5, scene_id="b"))
def test_several_scenes_in_one_document(a: SceneGraph, b: SceneGraph) -> None:
    both = to_rdflib_graph([a, b])
    assert len(both) == len(to_rdflib_graph(a)) + len(to_rdflib_graph(b))
    for fmt in ("turtle", "ntriples"):
        assert isomorphic(_parse(serialize_scenes([a, b], fmt), fmt), both)


def test_ntriples_is_one_triple_per_line_and_iris_need_no_escaping() -> None:
    g = hostile_scene()
    text = serialize_scenes(g, "ntriples")
    lines = text.splitlines(keepends=True)
    assert all(line.endswith(" .\n") for line in lines)
    assert len(lines) == len(to_rdflib_graph(g))
    iri_chars = re.compile(r"[A-Za-z0-9\-._~%:/#]*")
    for line in lines:
        for iri in re.findall(r"<([^>]*)>", line.split('"', 1)[0]):
            assert iri_chars.fullmatch(iri), iri


def test_the_rdf_mapping() -> None:
    """The fixed names that the SPARQL executors are written against."""
    g = SceneGraph(
        SceneMeta("s 1", name="kitchen", provenance={"ply": "abc"}),
        (
            Entity(3, "cup", (1.0, 2.0, 0.5), (0.9, 1.9, 0.4), (1.1, 2.1, 0.6), "ext3", None, 7),
            Entity(
                7,
                "table",
                (1.0, 2.0, 0.2),
                (0.0, 0.0, 0.0),
                (2.0, 4.0, 0.4),
                attributes=(Attribute("color", "red"),),
            ),
        ),
        (Relation(3, 7, "supported_by", {"distance": 0.25}),),
        (View(0, "frame0", 64, 48),),
        (MaskRecord(0, 2, 3, "mug", 0.5),),
    )
    out = _parse(serialize_scenes(g, "ntriples"), "ntriples")
    s = URIRef("https://w3id.org/causalsplat/scene/s%201")
    cup = URIRef("https://w3id.org/causalsplat/scene/s%201/entity/3")
    table = URIRef(str(s) + "/entity/7")
    assert URIRef(scene_iri("s 1")) == s and URIRef(entity_iri("s 1", 3)) == cup
    assertion = URIRef(str(s) + "/relation/3/supported_by/7")
    ev = URIRef(str(assertion) + "/evidence/distance")
    geometry = URIRef(str(cup) + "/geometry")
    attr = URIRef(str(table) + "/attribute/color/red")
    mask = URIRef(str(s) + "/view/0/mask/2")
    prov = URIRef(str(s) + "/provenance/ply")
    expected = [
        (s, RDF.type, CSG.Scene),
        (s, RDF.type, BOT.Space),
        (s, CSG.sceneId, Literal("s 1")),
        (s, CSG.name, Literal("kitchen")),
        (s, CSG.units, Literal("m")),
        (s, CSG.upAxis, Literal("z")),
        (s, CSG.source, Literal("objects")),
        (s, CSG.provenance, prov),
        (prov, CSG.key, Literal("ply")),
        (prov, CSG.value, Literal("abc")),
        (s, BOT.containsElement, cup),
        (cup, RDF.type, CSG.Entity),
        (cup, RDF.type, BOT.Element),
        (cup, CSG.inScene, s),
        (cup, CSG.localId, Literal(3)),
        (cup, CSG.externalId, Literal("ext3")),
        (cup, CSG.category, Literal("cup")),
        (cup, RDFS.label, Literal("cup")),
        (cup, CSG.centroidZ, Literal("0.5", datatype=rdflib.XSD.double)),
        (cup, CSG.minX, Literal("0.9", datatype=rdflib.XSD.double)),
        (cup, CSG.maxY, Literal("2.1", datatype=rdflib.XSD.double)),
        (cup, CSG.pointCount, Literal(7)),
        (cup, GEO.hasGeometry, geometry),
        (geometry, RDF.type, GEO.Geometry),
        (geometry, GEO.asWKT, Literal("POINT Z(1.0 2.0 0.5)", datatype=GEO.wktLiteral)),
        (table, CSG.hasAttribute, attr),
        (attr, RDF.type, CSG.Attribute),
        (attr, CSG.key, Literal("color")),
        (attr, CSG.value, Literal("red")),
        (attr, CSG.attributeSource, Literal("input")),
        (cup, CSG.supported_by, table),
        (assertion, RDF.type, CSG.RelationAssertion),
        (assertion, CSG.subject, cup),
        (assertion, CSG.predicate, CSG.supported_by),
        (assertion, CSG.object, table),
        (assertion, CSG.hasEvidence, ev),
        (ev, CSG.name, Literal("distance")),
        (ev, CSG.value, Literal("0.25", datatype=rdflib.XSD.double)),
        (URIRef(str(s) + "/view/0"), RDF.type, CSG.View),
        (URIRef(str(s) + "/view/0"), CSG.width, Literal(64)),
        (mask, RDF.type, CSG.Mask),
        (mask, CSG.inView, URIRef(str(s) + "/view/0")),
        (mask, CSG.maskIndex, Literal(2)),
        (mask, CSG.assignedTo, cup),
        (mask, CSG.label, Literal("mug")),
        (mask, CSG.score, Literal("0.5", datatype=rdflib.XSD.double)),
    ]
    for triple in expected:
        assert triple in out, triple
    assert (cup, CSG.confidence, None) not in out  # optional values absent when None
    assert (cup, CSG.caption, None) not in out
    assert (s, CSG.configHash, None) not in out


def test_evidence_off_leaves_only_direct_relation_triples() -> None:
    g = hostile_scene()
    out = _parse(serialize_scenes(g, "turtle", evidence=False), "turtle")
    assert not list(out.subjects(RDF.type, CSG.RelationAssertion))
    assert not list(out.subjects(CSG.hasEvidence, None))
    direct = {(str(a), str(b)) for a, b in out.subject_objects(CSG.above)}
    assert direct == {(entity_iri(g.scene_id, 0), entity_iri(g.scene_id, 1))}
    full = to_rdflib_graph(g)
    n_assert = sum(1 for _ in full.subjects(RDF.type, CSG.RelationAssertion))
    assert n_assert == len(g.relations)


def test_doubles_are_written_exactly() -> None:
    values = [0.1, -0.0, 5e-324, 1e16, 1.7976931348623157e308, 1 / 3, -2.5e-8]
    g = SceneGraph(
        SceneMeta("d"),
        tuple(Entity(i, "x", (v, v, v), (v, v, v), (v, v, v)) for i, v in enumerate(values)),
    )
    text = serialize_scenes(g, "ntriples")
    for v in values:
        assert f'"{v!r}"^^<http://www.w3.org/2001/XMLSchema#double>' in text
    out = _parse(text, "ntriples")
    xs = sorted(float(str(o)) for o in out.objects(None, CSG.centroidX))
    assert [repr(x) for x in xs] == [repr(v) for v in sorted(values)]


def test_empty_inputs() -> None:
    assert serialize_scenes([], "ntriples") == ""
    assert len(_parse(serialize_scenes([], "turtle"), "turtle")) == 0
    empty = SceneGraph(SceneMeta("empty"))
    for fmt in ("turtle", "ntriples", "jsonld"):
        assert isomorphic(_parse(serialize_scenes(empty, fmt), fmt), to_rdflib_graph(empty))


def test_write_scenes_to_a_path_and_a_stream(tmp_path) -> None:  # type: ignore[no-untyped-def]
    g = hostile_scene()
    for fmt in ("turtle", "ntriples", "jsonld"):
        path = tmp_path / f"out.{fmt}"
        write_scenes(g, path, fmt)
        assert path.read_text(encoding="utf-8") == serialize_scenes(g, fmt)
        buffer = io.StringIO()
        write_scenes([g], buffer, fmt)
        assert buffer.getvalue() == serialize_scenes(g, fmt)
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "out.jsonld",
        "out.ntriples",
        "out.turtle",
    ]


def test_bad_arguments() -> None:
    g = hostile_scene()
    with pytest.raises(RDFFormatError, match="rdfxml"):
        serialize_scenes(g, "rdfxml")
    with pytest.raises(InvalidSceneError, match="given twice"):
        serialize_scenes([g, g], "turtle")
    with pytest.raises(InvalidSceneError, match="SceneGraph"):
        serialize_scenes(["not a graph"], "turtle")  # type: ignore[list-item]
