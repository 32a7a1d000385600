"""Scenes as named graphs: ``GRAPH ?g``, ``FROM`` / ``FROM NAMED`` and a dataset given beside
the query, the same on both engines."""

from __future__ import annotations

import pytest

from graph_store.errors import SparqlArgumentError
from graph_store.rdf import RdfView
from graph_store.rdf.iris import scene_iri
from tests.strategies import random_scene

A, B = random_scene("room-a", 6, 8, seed=1), random_scene("room b", 5, 7, seed=2)
IA, IB = scene_iri("room-a"), scene_iri("room b")
COUNT = "SELECT (COUNT(*) AS ?n) {} WHERE {{ ?s ?p ?o }}"
PER_GRAPH = (
    "SELECT ?g (COUNT(*) AS ?n) {} WHERE {{ GRAPH ?g {{ ?s ?p ?o }} }} GROUP BY ?g ORDER BY ?g"
)


@pytest.fixture(scope="module", params=["oxigraph", "rdflib"])
def view(request: pytest.FixtureRequest) -> RdfView:
    return RdfView.from_graphs([A, B], backend=request.param)


def _n(view: RdfView, text: str, **kw: object) -> int:
    return int(view.query(text, isolate=False, **kw).rows[0][0])  # type: ignore[arg-type]


def test_each_scene_is_a_named_graph_and_the_default_graph_their_union(view: RdfView) -> None:
    alone = {g.scene_id: len(RdfView.from_graphs(g, backend=view.backend)) for g in (A, B)}
    rows = view.query(PER_GRAPH.format(""), isolate=False).rows
    assert rows == ((IB, alone["room b"]), (IA, alone["room-a"]))  # "room%20b" < "room-a"
    assert _n(view, COUNT.format("")) == len(view) == alone["room-a"] + alone["room b"]


def test_from_and_from_named_choose_among_the_scenes(view: RdfView) -> None:
    assert _n(view, COUNT.format(f"FROM <{IA}>")) == len(RdfView.from_graphs(A))
    assert _n(view, COUNT.format(f"FROM <{IA}> FROM <{IB}>")) == len(view)
    rows = view.query(PER_GRAPH.format(f"FROM NAMED <{IB}>"), isolate=False).rows
    assert [g for g, _ in rows] == [IB]
    # a dataset of named graphs only has an empty default graph
    assert _n(view, COUNT.format(f"FROM NAMED <{IB}>")) == 0
    assert _n(view, COUNT.format("FROM <https://example.org/elsewhere>")) == 0


def test_a_dataset_beside_the_query_replaces_its_own() -> None:
    view = RdfView.from_graphs([A, B], backend="oxigraph")
    assert _n(view, COUNT.format(f"FROM <{IA}>"), default_graphs=[IB]) == len(
        RdfView.from_graphs(B)
    )
    rows = view.query(PER_GRAPH.format(""), named_graphs=[IA], isolate=True).rows
    assert [g for g, _ in rows] == [IA]
    assert _n(view, COUNT.format(""), named_graphs=[IA]) == 0
    for bad in ("not an iri", "<urn:x>"):
        with pytest.raises(SparqlArgumentError, match="not an absolute IRI"):
            view.query(COUNT.format(""), default_graphs=[bad])
    with pytest.raises(SparqlArgumentError, match="default graphs are a list of graph IRIs"):
        view.query(COUNT.format(""), default_graphs=IA)  # type: ignore[arg-type]


def test_rdflib_takes_the_dataset_from_the_query_only() -> None:
    view = RdfView.from_graphs([A, B], backend="rdflib")
    with pytest.raises(SparqlArgumentError, match="needs the oxigraph engine"):
        view.query(COUNT.format(""), default_graphs=[IA], isolate=False)
