"""Both SPARQL engines give the same answers, and the answers agree with the scene graph."""

from __future__ import annotations

from collections import Counter

from hypothesis import given, settings
from hypothesis import strategies as st
from rdflib import URIRef

from graph_store import STORED_RELATION_TYPES, SceneGraph
from graph_store.rdf import RdfView, SparqlResult, entity_iri
from tests.strategies import scene_graphs

QUERIES = [
    # 2-hop join
    "SELECT ?a ?c WHERE { ?a csg:supported_by ?b . ?b csg:supported_by ?c }",
    "SELECT ?x ?y WHERE { ?x csg:near ?m . ?m csg:above ?y . ?y csg:category ?cat }",
    # OPTIONAL
    "SELECT ?e ?x ?conf WHERE { ?e a csg:Entity . OPTIONAL { ?e csg:externalId ?x }"
    " OPTIONAL { ?e csg:confidence ?conf } }",
    # FILTER
    "SELECT ?e ?z WHERE { ?e csg:centroidZ ?z FILTER(?z > 0 && ?z < 1e5) }",
    "SELECT ?a ?b WHERE { ?a csg:near ?b FILTER NOT EXISTS { ?b csg:near ?a } }",
    "SELECT ?e WHERE { ?e csg:category ?c FILTER(?c IN ('table', 'cup')) }",
    # aggregates
    "SELECT ?cat (COUNT(?e) AS ?n) WHERE { ?e csg:category ?cat } GROUP BY ?cat",
    "SELECT ?p (COUNT(*) AS ?n) WHERE { ?r csg:predicate ?p } GROUP BY ?p HAVING (COUNT(*) > 1)",
    "SELECT (COUNT(DISTINCT ?k) AS ?n) WHERE { ?e csg:hasAttribute ?a . ?a csg:key ?k }",
    # property paths
    "SELECT DISTINCT ?a ?b WHERE { ?a csg:supported_by+ ?b }",
    "SELECT DISTINCT ?a ?b WHERE { ?a (csg:above|csg:below)/csg:near ?b }",
    "SELECT DISTINCT ?a WHERE { ?a ^csg:supports ?b }",
    # evidence
    "SELECT ?a ?b ?n ?d WHERE { ?r csg:subject ?a ; csg:object ?b ; csg:hasEvidence ?ev ."
    " ?ev csg:name ?n ; csg:value ?d }",
    # ASK, CONSTRUCT
    "ASK { ?a csg:supported_by ?b . ?b csg:supported_by ?a }",
    "ASK { ?m a csg:Mask ; csg:assignedTo ?e }",
    "CONSTRUCT { ?b csg:below ?a } WHERE { ?a csg:above ?b }",
    "CONSTRUCT { ?e csg:category ?c } WHERE { ?e csg:category ?c ; csg:localId ?id }",
]


def _same(a: SparqlResult, b: SparqlResult) -> bool:
    if (a.kind, a.columns, a.boolean, a.truncated) != (b.kind, b.columns, b.boolean, b.truncated):
        return False
    return Counter(a.rows) == Counter(b.rows)  # order is unspecified without ORDER BY


@settings(max_examples=30, deadline=None)
@given(scene_graphs(max_entities=10))
def test_both_backends_give_the_same_answers(g: SceneGraph) -> None:
    ox_view = RdfView.from_graphs(g, backend="oxigraph")
    rdflib_view = RdfView.from_graphs(g, backend="rdflib")
    assert len(ox_view) == len(rdflib_view)
    for text in QUERIES:
        a, b = ox_view.query(text), rdflib_view.query(text)
        assert _same(a, b), text


@settings(max_examples=20, deadline=None)
@given(scene_graphs(max_entities=10), st.data())
def test_both_backends_agree_with_bindings(g: SceneGraph, data: st.DataObject) -> None:
    views = [RdfView.from_graphs(g, backend=b) for b in ("oxigraph", "rdflib")]
    category = data.draw(st.sampled_from([e.category for e in g.entities] or ["none"]))
    local_id = data.draw(st.sampled_from([e.id for e in g.entities] or [0]))
    cases = [
        ("SELECT ?e ?id WHERE { ?e csg:category ?cat ; csg:localId ?id }", {"cat": category}),
        ("SELECT ?b WHERE { ?a csg:localId ?id ; ?rel ?b . ?b a csg:Entity }", {"id": local_id}),
        ("SELECT (COUNT(?e) AS ?n) WHERE { ?e csg:category ?cat }", {"cat": category}),
        ("ASK { ?e csg:category ?cat }", {"cat": category}),
    ]
    for text, bindings in cases:
        a, b = (v.query(text, bindings=bindings) for v in views)
        assert _same(a, b), text
    expected = sorted(e.id for e in g.entities if e.category == category)
    got = views[0].query(cases[0][0], bindings=cases[0][1])
    assert sorted(row[1] for row in got.rows) == expected


def _count(view: RdfView, text: str, **bindings: object) -> int:
    (row,) = view.query(text, bindings=bindings).rows
    assert isinstance(row[0], int)
    return row[0]


@settings(max_examples=25, deadline=None)
@given(
    st.lists(scene_graphs(max_entities=8), min_size=1, max_size=3, unique_by=lambda g: g.scene_id),
    st.sampled_from(["oxigraph", "rdflib"]),
)
def test_counts_equal_the_scene_graphs(graphs: list[SceneGraph], backend: str) -> None:
    view = RdfView.from_graphs(graphs, backend=backend)
    for g in graphs:
        sid = g.scene_id
        n_entities = (
            "SELECT (COUNT(?e) AS ?n) WHERE { ?e a csg:Entity ; csg:inScene/csg:sceneId ?sid }"
        )
        assert _count(view, n_entities, sid=sid) == len(g.entities)
        for rel in STORED_RELATION_TYPES:
            by_type = (
                f"SELECT (COUNT(*) AS ?n) WHERE {{ ?a csg:{rel.value} ?b ."
                " ?a csg:inScene/csg:sceneId ?sid }"
            )
            assert _count(view, by_type, sid=sid) == len(g.relations_of(rel)), rel
        n_assertions = (
            "SELECT (COUNT(?r) AS ?n) WHERE { ?r a csg:RelationAssertion ;"
            " csg:subject/csg:inScene/csg:sceneId ?sid }"
        )
        assert _count(view, n_assertions, sid=sid) == len(g.relations)
        n_masks = "SELECT (COUNT(?m) AS ?n) WHERE { ?m csg:inView/csg:inScene/csg:sceneId ?sid }"
        assert _count(view, n_masks, sid=sid) == len(g.masks)
        for e in g.entities[:3]:
            out = view.query(
                "SELECT ?b WHERE { ?a ?p ?b . ?b a csg:Entity }",
                bindings={"a": URIRef(entity_iri(sid, e.id))},
            )
            expected = Counter(entity_iri(sid, r.dst) for r in g.relations if r.src == e.id)
            assert Counter(row[0] for row in out.rows) == expected


def test_evidence_off_gives_no_assertions() -> None:
    from tests.strategies import random_scene

    g = random_scene("s", 20, 30, seed=7)
    for backend in ("oxigraph", "rdflib"):
        with_ev = RdfView.from_graphs(g, backend=backend)
        without = RdfView.from_graphs(g, backend=backend, evidence=False)
        count = "SELECT (COUNT(*) AS ?n) WHERE { ?r a csg:RelationAssertion }"
        assert _count(with_ev, count) == len(g.relations)
        assert _count(without, count) == 0
        direct = "SELECT (COUNT(*) AS ?n) WHERE { ?a ?p ?b . ?b a csg:Entity . ?a a csg:Entity }"
        assert _count(without, direct) == _count(with_ev, direct) == len(g.relations)
