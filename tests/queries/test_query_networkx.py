"""The reference executor walks plain dicts laid out as its networkx graphs are: same
nodes, neighbours and keys in the same order (so every set it builds is built in the same
order), and running a program does not import networkx."""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Mapping

from hypothesis import given, settings

from graph_store.types import SceneGraph
from queries.networkx_executor import NetworkxExecutor, _Adjacency
from tests.conftest import REPO_ROOT
from tests.strategies import scene_graphs

Layout = list[tuple[int, list[tuple[int, list[str]]]]]


def _rows(adj: Mapping[int, Mapping[int, Mapping[str, object]]]) -> Layout:
    """Nodes, their neighbours and the keys of each edge, in iteration order."""
    return [(n, [(v, list(keys)) for v, keys in nbrs.items()]) for n, nbrs in adj.items()]


@settings(max_examples=200, deadline=None)
@given(scene_graphs(max_entities=16))
def test_adjacency_is_networkx_layout(graph: SceneGraph) -> None:
    adj, ex = _Adjacency(graph), NetworkxExecutor(graph)
    g, sup = ex.nx_graph, ex.support
    assert (_rows(adj.succ), _rows(adj.pred)) == (_rows(g._succ), _rows(g._pred))
    assert (_rows(adj.sup_succ), _rows(adj.sup_pred)) == (_rows(sup._succ), _rows(sup._pred))
    assert list(adj.succ) == list(ex.nx_graph.nodes) == list(ex.support.nodes)


RUN = """
import sys
from graph_store.types import Entity, Relation, RelationType, SceneGraph, SceneMeta
from queries import GraphQuery
from queries.networkx_executor import NetworkxExecutor

box = lambda i, z: Entity(i, "box", (0.0, 0.0, z), (-1.0, -1.0, z - 0.5), (1.0, 1.0, z + 0.5))
graph = SceneGraph(
    SceneMeta("s"), (box(1, 0.5), box(2, 1.5)), (Relation(2, 1, RelationType.SUPPORTED_BY),)
)
program = GraphQuery.model_validate({"query_type": "counterfactual", "steps": [
    {"op": "scene"}, {"op": "filter_category", "inputs": [0], "value": "box"},
    {"op": "argmin", "inputs": [1], "metric": "z", "k": 1},
    {"op": "fall_if_removed", "inputs": [2]}], "answer_step": 3})
result = NetworkxExecutor(graph).run(program)
print(sorted(result.answer), "networkx" in sys.modules)
"""


def test_running_a_program_does_not_import_networkx() -> None:
    proc = subprocess.run(
        [sys.executable, "-c", RUN], capture_output=True, text=True, cwd=REPO_ROOT, check=True
    )
    assert proc.stdout.split() == ["[2]", "False"], proc.stdout + proc.stderr
