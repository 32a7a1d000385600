"""The executors agree: random valid programs over random scene graphs give equal results
(answer, every step's set, support paths) on networkx, in plain dicts (memory), SQL (SQLite,
PostgreSQL) and SPARQL (rdflib, Oxigraph)."""

from __future__ import annotations

from collections.abc import Callable

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from graph_store.types import SceneGraph
from queries import Executor, GraphQuery
from queries.networkx_executor import NetworkxExecutor
from tests.queries.query_strategies import programs, scenes

MakeExecutor = Callable[[SceneGraph], Executor]
PER_SCENE = 4
_SETTINGS = {
    "deadline": None,
    "suppress_health_check": [HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
}


def check_parity(make_backend: MakeExecutor, graph: SceneGraph, batch: list[GraphQuery]) -> None:
    reference = NetworkxExecutor(graph)
    backend = make_backend(graph)
    for program in batch:
        expected = reference.run(program)
        got = backend.run(program)
        if got != expected:
            diffs = [
                f"  v{i}: reference {a!r}, {backend.name} {b!r}"
                for i, (a, b) in enumerate(zip(expected.steps, got.steps, strict=True))
                if a != b
            ]
            if got.support_paths != expected.support_paths:
                diffs.append(f"  paths: {expected.support_paths} vs {got.support_paths}")
            raise AssertionError(
                f"{backend!r} disagrees with the reference on\n{program.to_text()}\n"
                + "\n".join(diffs)
            )


def run_many(make_backend: MakeExecutor, scenes_to_try: int) -> int:
    """Check ``scenes_to_try`` random scenes; the number of programs checked."""
    checked: list[GraphQuery] = []

    @settings(max_examples=scenes_to_try, **_SETTINGS)  # type: ignore[arg-type]
    @given(graph=scenes(), batch=st.lists(programs(), min_size=PER_SCENE, max_size=PER_SCENE))
    def check(graph: SceneGraph, batch: list[GraphQuery]) -> None:
        check_parity(make_backend, graph, batch)
        checked.extend(batch)

    check()
    return len(checked)


def test_backends_match_reference(make_backend: MakeExecutor) -> None:
    """The default run: about 40 programs per backend."""
    assert run_many(make_backend, 10) >= 40


@pytest.mark.slow
def test_backends_match_reference_many(make_backend: MakeExecutor) -> None:
    """The slow run: at least 500 programs per backend."""
    assert run_many(make_backend, 130) >= 500
