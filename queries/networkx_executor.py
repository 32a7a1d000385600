"""The reference executor: a program evaluated on networkx graphs of the scene.

The scene is a networkx ``MultiDiGraph`` with one node per entity (id as node, the entity
as the ``entity`` attribute) and one edge per stored relation (``src -> dst``, keyed by the
relation type); support is also kept as a ``DiGraph`` with an edge ``x -> y`` for every
``x`` resting on ``y`` (:func:`build_graph`, :func:`support_graph`). Relations are read off
the multigraph's adjacency, a support closure is :func:`networkx.ancestors` in the support
graph (everything with a path down to the removed entity), and a counterfactual's fall
rounds take each entity's supporters from its successors there. Every rule is the one
written in :mod:`queries.semantics`; the SQL and SPARQL executors and the reasoner's fast
in-memory executor (:mod:`queries.memory_executor`) are held to this one by the tests.
Imports networkx.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

import networkx as nx

from graph_store.types import RelationType, SceneGraph
from queries._in_memory import InMemoryExecutor
from queries.semantics import DEFAULT_CONFIG, QueryConfig


def build_graph(graph: SceneGraph) -> nx.MultiDiGraph:
    """The networkx view of a scene graph (entities as nodes, relations as keyed edges)."""
    g = nx.MultiDiGraph(scene_id=graph.scene_id)
    for e in graph.entities:
        g.add_node(e.id, entity=e)
    for r in graph.relations:
        g.add_edge(r.src, r.dst, key=r.type.value)
    return g


def support_graph(g: nx.MultiDiGraph) -> nx.DiGraph:
    """``x -> y`` for every ``x supported_by y`` or ``y supports x`` edge."""
    sup = nx.DiGraph()
    sup.add_nodes_from(g.nodes)
    for u, v, key in g.edges(keys=True):
        if key == RelationType.SUPPORTED_BY.value:
            sup.add_edge(u, v)
        elif key == RelationType.SUPPORTS.value:
            sup.add_edge(v, u)
    return sup


class NetworkxExecutor(InMemoryExecutor):
    """Runs programs on networkx graphs of an in-memory scene graph (the reference).

    Attributes:
        nx_graph: the scene as a ``MultiDiGraph`` (:func:`build_graph`).
        support: the support ``DiGraph`` (:func:`support_graph`).
    """

    name = "networkx"

    def __init__(self, graph: SceneGraph, config: QueryConfig = DEFAULT_CONFIG) -> None:
        super().__init__(graph, config)
        self.nx_graph = build_graph(graph)
        self.support = support_graph(self.nx_graph)

    def _nodes(self) -> Iterable[int]:
        nodes: Iterable[int] = self.nx_graph.nodes
        return nodes

    def _related(self, anchor: int, relation: RelationType) -> Iterable[int]:
        forward, inverse = relation.value, relation.inverse.value
        yield from (u for u, keys in self.nx_graph.pred[anchor].items() if forward in keys)
        yield from (v for v, keys in self.nx_graph.succ[anchor].items() if inverse in keys)

    def _resting_on(self, entities: frozenset[int]) -> frozenset[int]:
        out: set[int] = set()
        for x in entities:
            above = nx.ancestors(self.support, x)
            out |= above
            if any(p == x or p in above for p in self.support.succ[x]):
                out.add(x)  # x rests on itself through a cycle of support edges
        return frozenset(out)

    def _supporters(self) -> Mapping[int, Iterable[int]]:
        supporters: Mapping[int, Iterable[int]] = self.support.succ
        return supporters
