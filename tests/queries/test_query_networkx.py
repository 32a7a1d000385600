"""The reference executor runs on networkx; the memory executor walks plain dicts laid out
as those networkx graphs are (same nodes, neighbours and keys in the same order), and
running a program there does not import networkx."""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Mapping

import networkx as nx
import pytest
from hypothesis import given, settings

from graph_store.types import Entity, Relation, RelationType, SceneGraph, SceneMeta
from queries import GraphQuery
from queries.memory_executor import Adjacency, MemoryExecutor
from queries.networkx_executor import NetworkxExecutor
from tests.conftest import REPO_ROOT
from tests.strategies import scene_graphs

Layout = list[tuple[int, list[tuple[int, list[str]]]]]


def _rows(adj: Mapping[int, Mapping[int, Mapping[str, object]]]) -> Layout:
    """Nodes, their neighbours and the keys of each edge, in iteration order."""
    return [(n, [(v, list(keys)) for v, keys in nbrs.items()]) for n, nbrs in adj.items()]


@settings(max_examples=200, deadline=None)
@given(scene_graphs(max_entities=16))
def test_memory_adjacency_is_the_networkx_layout(graph: SceneGraph) -> None:
    adj, ex = Adjacency(graph), NetworkxExecutor(graph)
    g, sup = ex.nx_graph, ex.support
    assert isinstance(g, nx.MultiDiGraph) and isinstance(sup, nx.DiGraph)
    assert (_rows(adj.succ), _rows(adj.pred)) == (_rows(g._succ), _rows(g._pred))
    assert (_rows(adj.sup_succ), _rows(adj.sup_pred)) == (_rows(sup._succ), _rows(sup._pred))
    assert list(adj.succ) == list(g.nodes) == list(sup.nodes)


def _box(i: int, z: float) -> Entity:
    return Entity(i, "box", (0.0, 0.0, z), (-1.0, -1.0, z - 0.5), (1.0, 1.0, z + 0.5))


#: Three boxes stacked (3 on 2 on 1) and a fourth beside them.
STACK = SceneGraph(
    SceneMeta("s"),
    (_box(1, 0.5), _box(2, 1.5), _box(3, 2.5), _box(4, 0.5)),
    (
        Relation(2, 1, RelationType.SUPPORTED_BY),
        Relation(2, 3, RelationType.SUPPORTS),
    ),
)
FALL = GraphQuery.model_validate({"query_type": "counterfactual", "steps": [
    {"op": "scene"}, {"op": "filter_category", "inputs": [0], "value": "box"},
    {"op": "argmin", "inputs": [1], "metric": "z", "k": 1},
    {"op": "fall_if_removed", "inputs": [2]}], "answer_step": 3})  # fmt: skip
CLOSURE = GraphQuery.model_validate({"query_type": "counterfactual", "steps": [
    {"op": "scene"}, {"op": "filter_category", "inputs": [0], "value": "box"},
    {"op": "argmin", "inputs": [1], "metric": "z", "k": 1},
    {"op": "support_closure", "inputs": [2]}], "answer_step": 3})  # fmt: skip


def test_the_reference_uses_networkx_algorithms(monkeypatch: pytest.MonkeyPatch) -> None:
    calls: list[object] = []
    real = nx.ancestors

    def ancestors(g: nx.DiGraph, source: object) -> set[object]:
        calls.append(source)
        return real(g, source)

    monkeypatch.setattr(nx, "ancestors", ancestors)
    ex = NetworkxExecutor(STACK)
    assert ex.run(CLOSURE).answer == (2, 3)
    assert calls == [1]  # the lowest box: its closure is networkx's ancestors in the support graph
    assert ex.run(FALL).answer == (2, 3)
    assert ex.run(FALL) == MemoryExecutor(STACK).run(FALL)


def test_a_support_cycle_rests_on_itself() -> None:
    """Both executors count an entity on a cycle of support edges in its own closure."""
    graph = SceneGraph(
        SceneMeta("s"),
        (_box(1, 0.5), _box(2, 1.5)),
        (Relation(2, 1, RelationType.SUPPORTED_BY), Relation(1, 2, RelationType.SUPPORTED_BY)),
    )
    ref, fast = NetworkxExecutor(graph).run(CLOSURE), MemoryExecutor(graph).run(CLOSURE)
    assert ref == fast and ref.answer == (1, 2)


RUN = """
import sys
from graph_store.types import Entity, Relation, RelationType, SceneGraph, SceneMeta
from queries import GraphQuery
from queries.memory_executor import MemoryExecutor

box = lambda i, z: Entity(i, "box", (0.0, 0.0, z), (-1.0, -1.0, z - 0.5), (1.0, 1.0, z + 0.5))
graph = SceneGraph(
    SceneMeta("s"), (box(1, 0.5), box(2, 1.5)), (Relation(2, 1, RelationType.SUPPORTED_BY),)
)
program = GraphQuery.model_validate({"query_type": "counterfactual", "steps": [
    {"op": "scene"}, {"op": "filter_category", "inputs": [0], "value": "box"},
    {"op": "argmin", "inputs": [1], "metric": "z", "k": 1},
    {"op": "fall_if_removed", "inputs": [2]}], "answer_step": 3})
print(list(MemoryExecutor(graph).run(program).answer), "networkx" in sys.modules)
"""


def test_the_memory_executor_does_not_import_networkx() -> None:
    proc = subprocess.run(
        [sys.executable, "-c", RUN], capture_output=True, text=True, cwd=REPO_ROOT, check=True
    )
    assert proc.stdout.split() == ["[2]", "False"], proc.stdout + proc.stderr


def test_scene_run_on_networkx_uses_networkx_graphs(tmp_path: object) -> None:
    from causalsplat.api import open_store

    store = open_store("sqlite://")
    store.graph_store.save_scene(STACK)
    scene = store.scene("s")
    ref = scene.run(FALL, executor="networkx")
    assert ref.executor == "networkx" and ref.answer == (2, 3)
    assert scene.run(FALL, executor="memory") == ref
    assert scene._reasoning_context().executor.name == "memory"
