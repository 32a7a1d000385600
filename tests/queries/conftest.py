"""Fixtures of the query tests: one factory per execution backend.

A factory takes a :class:`SceneGraph` and returns an executor over it: the networkx
reference, the memory executor (plain dicts), SQL on a SQLite or PostgreSQL store (the
graph saved into it first), or SPARQL on an rdflib or Oxigraph store of its RDF view.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from graph_store.repository import GraphStore, open_store
from graph_store.types import SceneGraph
from queries import Executor
from queries.memory_executor import MemoryExecutor
from queries.networkx_executor import NetworkxExecutor
from queries.sparql_executor import SparqlExecutor
from queries.sql_executor import SqlExecutor

MakeExecutor = Callable[[SceneGraph], Executor]

#: Every backend but the reference.
BACKENDS = [
    "memory",
    "sqlite",
    pytest.param("postgres", marks=pytest.mark.postgres),
    "rdflib",
    "oxigraph",
]


def _factory(name: str, store: GraphStore | None) -> MakeExecutor:
    def make(graph: SceneGraph) -> Executor:
        if name == "networkx":
            return NetworkxExecutor(graph)
        if name == "memory":
            return MemoryExecutor(graph)
        if name in ("rdflib", "oxigraph"):
            return SparqlExecutor.from_graph(graph, name)
        assert store is not None
        store.save_scene(graph, if_exists="replace")
        return SqlExecutor(store.engine, graph.scene_id)

    return make


def _store_for(name: str, request: pytest.FixtureRequest, tmp_path: Path) -> GraphStore | None:
    if name == "sqlite":
        return open_store(f"sqlite:///{tmp_path / 'queries.db'}")
    if name == "postgres":
        return open_store(str(request.getfixturevalue("postgres_url")))
    return None


@pytest.fixture(params=BACKENDS)
def make_backend(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[MakeExecutor]:
    """A factory of executors of one non-reference backend."""
    store = _store_for(request.param, request, tmp_path)
    try:
        yield _factory(request.param, store)
    finally:
        if store is not None:
            store.close()


@pytest.fixture(params=["networkx", *BACKENDS])
def make_any(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[MakeExecutor]:
    """A factory of executors of every backend, the reference included."""
    store = _store_for(request.param, request, tmp_path)
    try:
        yield _factory(request.param, store)
    finally:
        if store is not None:
            store.close()
