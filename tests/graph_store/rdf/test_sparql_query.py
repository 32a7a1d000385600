"""RdfView.query: prefixes, typed bindings, row limits, timeouts and result values."""

from __future__ import annotations

import json
import threading
import time

import numpy as np
import pyoxigraph as ox
import pytest
from rdflib import Literal, URIRef

from graph_store import (
    Attribute,
    Entity,
    Relation,
    SceneGraph,
    SceneMeta,
    SparqlError,
    SparqlResourceError,
    SparqlRowLimitError,
    SparqlTimeoutError,
)
from graph_store.rdf import RdfView, SparqlResult, entity_iri, scene_iri
from graph_store.rdf._sparql_worker import can_isolate
from tests.strategies import random_scene

BACKENDS = ("oxigraph", "rdflib")
TRICKY = 'a "quoted" \\ } ; DROP ALL # \n <http://x/> ü'


def small_scene() -> SceneGraph:
    def box(i: int, cat: str, z: float, **kw: object) -> Entity:
        return Entity(i, cat, (0.0, 0.0, z), (-1.0, -1.0, z - 0.5), (1.0, 1.0, z + 0.5), **kw)  # type: ignore[arg-type]

    return SceneGraph(
        SceneMeta("kitchen"),
        (
            box(0, "floor", 0.0, external_id="f"),
            box(1, "table", 1.0, confidence=0.75),
            box(2, "cup", 2.0, attributes=(Attribute("color", "red"),)),
            box(3, TRICKY, 3.0, caption="http://example.org/not-an-iri"),
        ),
        (
            Relation(1, 0, "supported_by", {"distance": 0.0}),
            Relation(2, 1, "supported_by", {"distance": 0.01}),
            Relation(3, 2, "supported_by"),
            Relation(2, 1, "above"),
            Relation(1, 2, "below"),
            Relation(0, 3, "near"),
        ),
    )


@pytest.fixture(scope="module", params=BACKENDS)
def view(request: pytest.FixtureRequest) -> RdfView:
    v = RdfView.from_graphs(small_scene(), backend=request.param)
    assert v.backend == request.param and v.scene_ids == ("kitchen",)
    return v


def e(i: int) -> str:
    return entity_iri("kitchen", i)


def test_predeclared_prefixes_and_user_prefixes_win(view: RdfView) -> None:
    result = view.query("SELECT ?a ?b WHERE { ?a csg:above ?b }")
    assert result == SparqlResult("select", ("a", "b"), ((e(2), e(1)),))
    mine = view.query("PREFIX csg: <http://other/> SELECT ?a WHERE { ?a csg:above ?b }")
    assert mine.rows == ()
    typed = view.query("SELECT ?x WHERE { ?x a bot:Element ; rdfs:label 'table' }")
    assert typed.rows == ((e(1),),)


def test_python_values_of_terms(view: RdfView) -> None:
    r = view.query(
        "SELECT ?id ?cat ?z ?conf ?ext WHERE { ?e csg:localId ?id ; csg:category ?cat ;"
        " csg:centroidZ ?z . OPTIONAL { ?e csg:confidence ?conf }"
        " OPTIONAL { ?e csg:externalId ?ext } } ORDER BY ?id"
    )
    assert r.rows == (
        (0, "floor", 0.0, None, "f"),
        (1, "table", 1.0, 0.75, None),
        (2, "cup", 2.0, None, None),
        (3, TRICKY, 3.0, None, None),
    )
    assert [type(v) for v in r.rows[1][:4]] == [int, str, float, float]
    ask = view.query("ASK { ?a csg:near ?b }")
    assert (ask.kind, ask.boolean, ask.rows, ask.columns) == ("ask", True, (), ())
    b = view.query("SELECT (1 < 2 AS ?t) (STR(?s) AS ?iri) WHERE { ?s csg:sceneId 'kitchen' }")
    assert b.rows == ((True, scene_iri("kitchen")),)


def test_construct_and_describe(view: RdfView) -> None:
    r = view.query("CONSTRUCT { ?b csg:below ?a } WHERE { ?a csg:above ?b }")
    assert r.kind == "graph" and r.columns == ("subject", "predicate", "object")
    assert r.rows == ((e(1), "https://w3id.org/causalsplat/ns#below", e(2)),)
    d = view.query("DESCRIBE ?e WHERE { ?e csg:externalId 'f' }")
    assert (e(0), "https://w3id.org/causalsplat/ns#category", "floor") in d.rows


@pytest.mark.parametrize(
    ("bindings", "expected"),
    [
        ({"cat": "cup"}, [2]),
        ({"?cat": TRICKY}, [3]),
        ({"$id": 1}, [1]),
        ({"z": 2.0}, [2]),
        ({"z": np.float32(2.0), "id": np.int64(2)}, [2]),
        ({"e": URIRef(e(0))}, [0]),
        ({"e": ox.NamedNode(e(3))}, [3]),
        ({"cat": Literal("table")}, [1]),
        ({"cat": ox.Literal("floor")}, [0]),
        ({"cat": "cup", "id": 2}, [2]),
        ({"cat": "cup", "id": 1}, []),
        ({"cat": e(2)}, []),  # a str that looks like an IRI is still a plain literal
        ({"id": "1"}, []),  # and a numeric-looking str is not a number
        ({"id": 1.0}, []),  # a double is not the integer 1 as an RDF term
    ],
)
def test_bindings_are_typed_terms(
    view: RdfView, bindings: dict[str, object], expected: list[int]
) -> None:
    r = view.query(
        "SELECT ?id WHERE { ?e csg:localId ?id ; csg:category ?cat ; csg:centroidZ ?z }",
        bindings=bindings,
    )
    assert sorted(row[0] for row in r.rows) == expected


def test_bindings_reach_filters_and_aggregates(view: RdfView) -> None:
    r = view.query(
        "SELECT ?id WHERE { ?e csg:localId ?id ; csg:centroidZ ?z FILTER(?z >= ?min) }",
        bindings={"min": 2},
    )
    assert sorted(row[0] for row in r.rows) == [2, 3]
    n = view.query(
        "SELECT (COUNT(?a) AS ?n) WHERE { ?a csg:supported_by ?b . ?b csg:category ?c }",
        bindings={"c": "table"},
    )
    assert n.rows == ((1,),)
    ask = view.query(
        "ASK { ?e csg:caption ?cap }", bindings={"cap": "http://example.org/not-an-iri"}
    )
    assert ask.boolean is True
    sub = view.query(
        "SELECT ?a WHERE { { SELECT ?a WHERE { ?a csg:supported_by ?b } } }",
        bindings={"a": URIRef(e(3))},
    )
    assert sub.rows == ((e(3),),)


@pytest.mark.parametrize(
    "bindings",
    [
        {"x": object()},
        {"x": [1, 2]},
        {"x": None},
        {"not a name": 1},
        {"x": URIRef("http://a/> } ; DROP ALL ; <http://b")},
    ],
)
def test_bad_bindings(view: RdfView, bindings: dict[str, object]) -> None:
    with pytest.raises(SparqlError):
        view.query("SELECT ?x WHERE { ?x csg:localId ?id }", bindings=bindings)


def test_row_limit(view: RdfView) -> None:
    text = "SELECT ?s ?p ?o WHERE { ?s ?p ?o }"
    total = len(view.query(text, limit=100_000).rows)
    assert total == len(view)
    r = view.query(text, limit=5)
    assert len(r.rows) == 5 and r.truncated
    exact = view.query(text, limit=total)
    assert len(exact.rows) == total and not exact.truncated
    with pytest.raises(SparqlRowLimitError, match="more than 5"):
        view.query(text, limit=5, on_limit="error")
    assert view.query(text, limit=0).rows == ()
    graph = view.query("CONSTRUCT WHERE { ?s ?p ?o }", limit=3)
    assert len(graph.rows) == 3 and graph.truncated
    with pytest.raises(ValueError, match="limit"):
        view.query(text, limit=-1)


def test_select_star_columns_are_sorted(view: RdfView) -> None:
    r = view.query("SELECT * WHERE { ?zeta csg:above ?alpha . ?alpha csg:category ?mid }")
    assert r.columns == ("alpha", "mid", "zeta")
    assert r.rows == ((e(1), "table", e(2)),)


def test_to_json(view: RdfView) -> None:
    r = view.query(
        "SELECT ?id ?conf WHERE { ?e csg:localId ?id OPTIONAL { ?e csg:confidence ?conf } }"
        " ORDER BY ?id",
        limit=2,
    )
    doc = r.to_json()
    assert doc == {
        "kind": "select",
        "columns": ["id", "conf"],
        "rows": [[0, None], [1, 0.75]],
        "boolean": None,
        "truncated": True,
    }
    assert json.loads(json.dumps(doc)) == doc


def _sparql_threads() -> int:
    return sum(1 for t in threading.enumerate() if t.name == "sparql-query")


def _wait_for_workers(before: int) -> bool:
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        if _sparql_threads() <= before:
            return True
        time.sleep(0.05)
    return False


@pytest.mark.parametrize("isolate", [True, False], ids=["process", "thread"])
@pytest.mark.parametrize("backend", BACKENDS)
def test_timeout_stops_an_explosive_query(backend: str, isolate: bool) -> None:
    view = RdfView.from_graphs(random_scene("s", 40, 60, seed=5), backend=backend)
    before = _sparql_threads()
    explosive = "SELECT * WHERE { ?a ?b ?c . ?d ?e ?f . ?g ?h ?i }"  # ~1e9 rows
    with pytest.raises(SparqlTimeoutError, match=r"0\.2 s"):
        view.query(explosive, limit=10**12, timeout_s=0.2, isolate=isolate)
    assert _wait_for_workers(before), "the abandoned evaluation did not stop"
    assert view.query("ASK { ?a csg:near ?b }", timeout_s=30, isolate=isolate).boolean is not None


def test_timeout_cancels_rdflib_inside_an_aggregate() -> None:
    view = RdfView.from_graphs(random_scene("s", 40, 60, seed=5), backend="rdflib")
    before = _sparql_threads()
    with pytest.raises(SparqlTimeoutError):
        view.query(
            "SELECT (COUNT(*) AS ?n) WHERE { ?a ?b ?c . ?d ?e ?f . ?g ?h ?i }",
            timeout_s=0.2,
            isolate=False,
        )
    assert _wait_for_workers(before), "the abandoned evaluation did not stop"


@pytest.mark.skipif(not can_isolate(), reason="no fork here")
def test_the_worker_is_reused_killed_on_timeout_and_bounded_in_memory() -> None:
    import os

    view = RdfView.from_graphs(random_scene("s", 40, 60, seed=5), backend="oxigraph")
    ask = "ASK { ?a csg:near ?b }"
    first = view.query(ask)
    (worker,) = view._idle  # one query so far: one worker forked, now idle
    assert worker._process is not None
    pid = worker._process.pid
    assert view.query(ask) == first and worker._process.pid == pid  # one fork, reused
    sort = "SELECT * WHERE { ?a ?b ?c . ?d ?e ?f . ?g ?h ?i } ORDER BY ?a ?d ?g ?c ?f ?i"
    with pytest.raises(SparqlTimeoutError, match=r"0\.3 s"):
        view.query(sort, timeout_s=0.3)  # still computing its first result when killed
    with pytest.raises(ProcessLookupError):
        os.kill(pid, 0)  # gone: its CPU and memory are back
    assert view.query(ask) == first  # a new worker
    with pytest.raises(SparqlResourceError, match="ran out of memory"):
        view.query(sort, timeout_s=600, memory_mb=64)
    assert view.query(ask, memory_mb=64) == first
    # the same answers as in a thread, for every kind of query
    for text in ("SELECT ?a ?b WHERE { ?a csg:near ?b } ORDER BY ?a ?b",
                 "CONSTRUCT { ?a csg:near ?b } WHERE { ?a csg:near ?b }", ask):  # fmt: skip
        assert view.query(text) == view.query(text, isolate=False)


def test_bad_arguments(view: RdfView) -> None:
    with pytest.raises(ValueError, match="timeout_s"):
        view.query("ASK {}", timeout_s=0)
    with pytest.raises(ValueError, match="on_limit"):
        view.query("ASK {}", on_limit="ignore")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="backend"):
        RdfView.from_graphs([], backend="jena")  # type: ignore[arg-type]


def test_rdflib_never_loads_graphs_while_evaluating(monkeypatch: pytest.MonkeyPatch) -> None:
    import rdflib.plugins.sparql as rdflib_sparql

    from graph_store.rdf import _sparql_backends

    seen: list[bool] = []
    original = _sparql_backends._CancellableMemory.triples

    def spy(self, pattern, context=None):  # type: ignore[no-untyped-def]
        seen.append(rdflib_sparql.SPARQL_LOAD_GRAPHS)
        return original(self, pattern, context)

    monkeypatch.setattr(_sparql_backends._CancellableMemory, "triples", spy)
    view = RdfView.from_graphs(small_scene(), backend="rdflib")
    assert rdflib_sparql.SPARQL_LOAD_GRAPHS is True
    assert view.query("SELECT ?a WHERE { ?a csg:above ?b }", isolate=False).rows == ((e(2),),)
    assert seen and not any(seen)
    assert rdflib_sparql.SPARQL_LOAD_GRAPHS is True  # restored afterwards
