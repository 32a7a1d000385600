"""The fast in-memory executor: the scene graph's adjacency in plain dicts.

The same steps as the reference :class:`~queries.networkx_executor.NetworkxExecutor`
(:class:`~queries._in_memory.InMemoryExecutor`), with the relations and the support graph
laid out as networkx lays out its ``MultiDiGraph`` and ``DiGraph`` (node -> neighbour ->
key, insertion ordered), in dicts: running a program imports no networkx, a sixth of a cold
``causalsplat ask``. The reasoner runs its programs here; the tests hold every result, and
the layout itself, to the networkx executor's.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

from graph_store.types import RelationType, SceneGraph
from queries._in_memory import InMemoryExecutor
from queries.semantics import DEFAULT_CONFIG, QueryConfig

#: ``node -> neighbour -> {key: None}``, insertion ordered (networkx's ``_succ`` / ``_pred``).
Neighbours = dict[int, dict[int, dict[str, None]]]


class Adjacency:
    """The scene graph and its support graph as networkx lays them out, in plain dicts.

    ``succ`` / ``pred``: the ``MultiDiGraph`` of
    :func:`~queries.networkx_executor.build_graph` (keys: relation types); ``sup_succ`` /
    ``sup_pred``: the ``DiGraph`` of :func:`~queries.networkx_executor.support_graph`
    (keys unused). Nodes are in entity order; neighbours and keys in the order edges were
    added.
    """

    def __init__(self, graph: SceneGraph) -> None:
        self.succ: Neighbours = {e.id: {} for e in graph.entities}
        self.pred: Neighbours = {e.id: {} for e in graph.entities}
        for r in graph.relations:
            keys = self.succ[r.src].setdefault(r.dst, {})
            keys[r.type.value] = None
            self.pred[r.dst][r.src] = keys
        self.sup_succ: Neighbours = {n: {} for n in self.succ}
        self.sup_pred: Neighbours = {n: {} for n in self.succ}
        on, under = RelationType.SUPPORTED_BY.value, RelationType.SUPPORTS.value
        for u, neighbours in self.succ.items():
            for v, keys in neighbours.items():
                for key in keys:
                    if key == on:
                        self._support(u, v)
                    elif key == under:
                        self._support(v, u)

    def _support(self, upper: int, lower: int) -> None:
        self.sup_succ[upper].setdefault(lower, {})
        self.sup_pred[lower].setdefault(upper, {})


class MemoryExecutor(InMemoryExecutor):
    """Runs programs on an in-memory scene graph, walking plain dicts (no networkx)."""

    name = "memory"

    def __init__(self, graph: SceneGraph, config: QueryConfig = DEFAULT_CONFIG) -> None:
        super().__init__(graph, config)
        self._adj = Adjacency(graph)

    def _nodes(self) -> Iterable[int]:
        return self._adj.succ

    def _related(self, anchor: int, relation: RelationType) -> Iterable[int]:
        forward, inverse = relation.value, relation.inverse.value
        yield from (u for u, keys in self._adj.pred[anchor].items() if forward in keys)
        yield from (v for v, keys in self._adj.succ[anchor].items() if inverse in keys)

    def _resting_on(self, entities: frozenset[int]) -> frozenset[int]:
        seen: set[int] = set()
        frontier = list(entities)
        while frontier:
            node = frontier.pop()
            for upper in self._adj.sup_pred[node]:
                if upper not in seen:
                    seen.add(upper)
                    frontier.append(upper)
        return frozenset(seen)

    def _supporters(self) -> Mapping[int, Iterable[int]]:
        return {x: set(lower) for x, lower in self._adj.sup_succ.items()}
