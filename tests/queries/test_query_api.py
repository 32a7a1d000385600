"""run_program / make_executor over a store, an engine or an in-memory graph; errors; the
RdfView endpoint; and the query path never importing torch."""

from __future__ import annotations

import subprocess
import sys

import pytest

from graph_store.errors import SceneNotFound
from graph_store.rdf import RdfView
from graph_store.repository import open_store
from queries import (
    EXECUTORS,
    QueryExecutionError,
    QueryValidationError,
    make_executor,
    run_program,
)
from queries.sparql_endpoints import RdfViewEndpoint
from queries.sparql_executor import SparqlExecutor
from tests.conftest import REPO_ROOT
from tests.queries.test_query_counterfactual import removal, scene

PROGRAM = removal(2).to_dict()  # both tables removed: the board and the cup fall


@pytest.mark.parametrize("executor", EXECUTORS)
def test_run_program_on_a_store_an_engine_and_a_graph(sqlite_url: str, executor: str) -> None:
    graph = scene()
    with open_store(sqlite_url) as store:
        store.save_scene(graph)
        by_store = run_program(store, "cf", PROGRAM, executor=executor)
        by_engine = run_program(store.engine, "cf", PROGRAM, executor=executor)
    by_graph = run_program(graph, "cf", PROGRAM, executor=executor)
    assert by_store.answer == (4, 5)
    assert by_store == by_engine == by_graph
    assert by_store.executor == executor
    rdflib = run_program(graph, "cf", PROGRAM, executor="sparql", sparql_backend="rdflib")
    assert rdflib == by_store


def test_rdf_view_endpoint_gives_the_same_answers() -> None:
    graph = scene()
    for backend in ("oxigraph", "rdflib"):
        view = RdfView.from_graphs(graph, backend=backend)  # type: ignore[arg-type]
        via_view = SparqlExecutor(RdfViewEndpoint(view), "cf").run(PROGRAM)
        assert via_view == run_program(graph, "cf", PROGRAM)


def test_errors(sqlite_url: str) -> None:
    with pytest.raises(QueryValidationError):  # validated before the source is looked at
        run_program(object(), "cf", {"query_type": "spatial", "steps": []})
    graph = scene()
    with pytest.raises(QueryExecutionError, match="unknown executor"):
        run_program(graph, "cf", PROGRAM, executor="cypher")
    with pytest.raises(QueryExecutionError, match="not 'other'"):
        run_program(graph, "other", PROGRAM)
    with pytest.raises(QueryExecutionError, match="GraphStore"):
        make_executor(object(), "cf", executor="sql")
    with open_store(sqlite_url) as store:
        for executor in EXECUTORS:
            with pytest.raises(SceneNotFound):
                run_program(store, "missing", PROGRAM, executor=executor)


def test_an_executor_runs_many_programs_and_sees_replaced_scenes(sqlite_url: str) -> None:
    graph = scene()
    with open_store(sqlite_url) as store:
        store.save_scene(graph)
        sql = make_executor(store, "cf", executor="sql")
        assert sql.run(PROGRAM).answer == (4, 5)
        assert sql.run(removal(6)).answer == (7, 8)
        smaller = type(graph)(graph.meta, graph.entities[:4], ())
        store.save_scene(smaller, if_exists="replace")
        assert sql.run(removal(2)).answer == ()
        assert "cf" in repr(sql)


SCRIPT = """
import sys
import queries
from graph_store.repository import open_store
from tests.queries.test_query_counterfactual import removal, scene
with open_store("sqlite://") as store:
    store.save_scene(scene())
    for executor in queries.EXECUTORS:
        assert queries.run_program(store, "cf", removal(2), executor=executor).answer == (4, 5)
heavy = sorted(m for m in ("torch", "causalsplat") if m in sys.modules)
print(",".join(heavy))
"""


def test_the_query_path_never_imports_torch() -> None:
    proc = subprocess.run(
        [sys.executable, "-c", SCRIPT], capture_output=True, text=True, cwd=REPO_ROOT, check=True
    )
    assert proc.stdout.strip() == "", f"imported: {proc.stdout.strip()}"


def test_sparql_executor_reads_scene_facts_once_until_refreshed() -> None:
    from graph_store import Entity, SceneGraph, SceneMeta

    graph = SceneGraph(
        meta=SceneMeta(scene_id="s"),
        entities=(
            Entity(1, "table", (0, 0, 0.4), (-0.5, -0.5, 0), (0.5, 0.5, 0.8)),
            Entity(2, "cup", (0, 0, 0.85), (-0.05, -0.05, 0.8), (0.05, 0.05, 0.9)),
        ),
    )
    executor = SparqlExecutor.from_graph(graph)
    program = {"query_type": "intrinsic", "steps": [{"op": "scene"}], "answer_step": 0}
    assert executor.run(program).answer == (1, 2)
    assert executor.cache["scene_ids"] == frozenset({1, 2})
    executor.cache["scene_ids"] = frozenset({1})  # what a stale cache would hold
    assert executor.run(program).answer == (1,)
    executor.refresh()
    assert executor.run(program).answer == (1, 2)
