"""Running programs: pick an executor for a store (or an in-memory graph) and a scene.

>>> store = open_store("sqlite:///scenes.db")                              # doctest: +SKIP
>>> result = run_program(store, "scene0000_00", program, executor="sql")   # doctest: +SKIP
>>> result.answer                                                          # doctest: +SKIP
(53,)

The executors give equal :class:`~queries.QueryResult` objects for every program:

* ``"networkx"`` (the reference): loads the scene graph and evaluates it on networkx graphs
  (imports networkx);
* ``"memory"``: the same in memory on plain dicts, without importing networkx (what the
  reasoner runs its programs on);
* ``"sql"``: SQL on the store's database (SQLite or PostgreSQL); for an in-memory graph, on a
  private in-memory SQLite copy;
* ``"sparql"``: SPARQL on the scene's RDF view in an Oxigraph store (``sparql_backend=
  "rdflib"`` for plain rdflib).

To run many programs on one scene, build the executor once with :func:`make_executor`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Literal

from sqlalchemy.engine import Engine

from graph_store.types import SceneGraph
from queries._base import Executor
from queries.errors import QueryExecutionError
from queries.model import GraphQuery
from queries.result import QueryResult
from queries.semantics import DEFAULT_CONFIG, QueryConfig

if TYPE_CHECKING:
    from graph_store.repository import GraphStore
    from queries.sparql_endpoints import SparqlBackendName

ExecutorName = Literal["networkx", "memory", "sql", "sparql"]
EXECUTORS: tuple[str, ...] = ("networkx", "memory", "sql", "sparql")
Source = Any  # a GraphStore, a SQLAlchemy Engine on a store, or a SceneGraph


def _store(source: Source) -> GraphStore:
    from graph_store.repository import GraphStore

    if isinstance(source, GraphStore):
        return source
    if isinstance(source, Engine):
        return GraphStore(source)
    raise QueryExecutionError(
        f"expected a GraphStore, a SQLAlchemy Engine or a SceneGraph, got {type(source).__name__}"
    )


def _graph(source: Source, scene_id: str) -> SceneGraph:
    if isinstance(source, SceneGraph):
        if source.scene_id != scene_id:
            raise QueryExecutionError(
                f"the graph given is scene {source.scene_id!r}, not {scene_id!r}"
            )
        return source
    return _store(source).load_scene(scene_id)


def make_executor(
    source: Source,
    scene_id: str,
    *,
    executor: ExecutorName | str = "networkx",
    config: QueryConfig = DEFAULT_CONFIG,
    sparql_backend: SparqlBackendName = "oxigraph",
) -> Executor:
    """An executor for one scene (see the module docstring for what each one needs)."""
    if executor == "networkx":
        from queries.networkx_executor import NetworkxExecutor

        return NetworkxExecutor(_graph(source, scene_id), config)
    if executor == "memory":
        from queries.memory_executor import MemoryExecutor

        return MemoryExecutor(_graph(source, scene_id), config)
    if executor == "sql":
        from queries.sql_executor import SqlExecutor

        if isinstance(source, SceneGraph):
            from graph_store.repository import open_store

            graph = _graph(source, scene_id)
            memory = open_store("sqlite://")
            memory.save_scene(graph)
            return SqlExecutor(memory.engine, scene_id, config)
        return SqlExecutor(_store(source).engine, scene_id, config)
    if executor == "sparql":
        from queries.sparql_executor import SparqlExecutor

        return SparqlExecutor.from_graph(_graph(source, scene_id), sparql_backend, config)
    raise QueryExecutionError(
        f"unknown executor {executor!r}; expected one of: {', '.join(EXECUTORS)}"
    )


def run_program(
    source: Source,
    scene_id: str,
    program: GraphQuery | str | bytes | dict[str, Any],
    *,
    executor: ExecutorName | str = "networkx",
    config: QueryConfig = DEFAULT_CONFIG,
    sparql_backend: SparqlBackendName = "oxigraph",
) -> QueryResult:
    """Validate ``program`` (a GraphQuery, its JSON or its dict) and run it on a scene.

    Raises :class:`~queries.QueryValidationError` for an invalid program (before touching
    the store), :class:`graph_store.SceneNotFound` for a missing scene and
    :class:`~queries.QueryExecutionError` for an unknown executor.
    """
    query = GraphQuery.parse(program)
    return make_executor(
        source, scene_id, executor=executor, config=config, sparql_backend=sparql_backend
    ).run(query)
