"""The reference executor: a program evaluated over the scene graph in memory.

The graph is a networkx ``MultiDiGraph`` with one node per entity (id as node, the entity
as the ``entity`` attribute) and one edge per stored relation (``src -> dst``, keyed by
the relation type); support is also kept as a ``DiGraph`` with an edge ``x -> y`` for
every ``x`` resting on ``y`` (:func:`build_graph`, :func:`support_graph`). The executor
walks the same adjacency in networkx's own layout (node -> neighbour -> key, insertion
ordered) held in plain dicts (:class:`_Adjacency`), so that running a program does not
import networkx (a sixth of a cold ``causalsplat ask``); :attr:`NetworkxExecutor.nx_graph`
and :attr:`NetworkxExecutor.support` build the networkx graphs on first use, and a test
holds their iteration orders equal to the dicts'. Every rule is the one written in
:mod:`queries.semantics`.
"""

from __future__ import annotations

from functools import cached_property
from typing import TYPE_CHECKING, Any

from graph_store.types import Entity, RelationType, SceneGraph
from queries._base import Executor, RunValue, run_sets, top_k
from queries.model import GraphQuery, Metric, Op, Step
from queries.result import QueryResult
from queries.semantics import (
    DEFAULT_CONFIG,
    PY,
    QueryConfig,
    SupportPath,
    attribute_filter,
    between,
    centre_coordinate,
    fall_rounds,
    metric_value,
    normalise_text,
    rank_texts,
    squared_distance,
    support_paths,
    view_relation,
)

if TYPE_CHECKING:
    import networkx as nx

#: ``node -> neighbour -> {key: None}``, insertion ordered (networkx's ``_succ`` / ``_pred``).
Neighbours = dict[int, dict[int, dict[str, None]]]


class _Adjacency:
    """The scene graph and its support graph as networkx lays them out, in plain dicts.

    ``succ`` / ``pred``: the ``MultiDiGraph`` of :func:`build_graph` (keys: relation
    types); ``sup_succ`` / ``sup_pred``: the ``DiGraph`` of :func:`support_graph` (keys
    unused). Nodes are in entity order; neighbours and keys in the order edges were added.
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


def build_graph(graph: SceneGraph) -> nx.MultiDiGraph:
    """The networkx view of a scene graph (entities as nodes, relations as keyed edges)."""
    import networkx as nx

    g = nx.MultiDiGraph(scene_id=graph.scene_id)
    for e in graph.entities:
        g.add_node(e.id, entity=e)
    for r in graph.relations:
        g.add_edge(r.src, r.dst, key=r.type.value)
    return g


def support_graph(g: nx.MultiDiGraph) -> nx.DiGraph:
    """``x -> y`` for every ``x supported_by y`` or ``y supports x`` edge."""
    import networkx as nx

    sup = nx.DiGraph()
    sup.add_nodes_from(g.nodes)
    for u, v, key in g.edges(keys=True):
        if key == RelationType.SUPPORTED_BY.value:
            sup.add_edge(u, v)
        elif key == RelationType.SUPPORTS.value:
            sup.add_edge(v, u)
    return sup


class NetworkxExecutor(Executor):
    """Runs programs on an in-memory scene graph (the reference semantics)."""

    name = "networkx"

    def __init__(self, graph: SceneGraph, config: QueryConfig = DEFAULT_CONFIG) -> None:
        super().__init__(graph.scene_id, config)
        self.graph = graph
        self._by_id: dict[int, Entity] = {e.id: e for e in graph.entities}
        self._adj = _Adjacency(graph)
        self._centre = _scene_centre(graph)

    @cached_property
    def nx_graph(self) -> nx.MultiDiGraph:
        """The scene as a networkx ``MultiDiGraph`` (:func:`build_graph`), built on first use."""
        return build_graph(self.graph)

    @cached_property
    def support(self) -> nx.DiGraph:
        """The support ``DiGraph`` (:func:`support_graph`), built on first use."""
        return support_graph(self.nx_graph)

    def _entity(self, entity_id: int) -> Entity:
        return self._by_id[entity_id]

    def _execute(self, program: GraphQuery) -> QueryResult:
        paths: list[SupportPath] = []
        handlers: dict[Op, Any] = {
            Op.SCENE: lambda i, s, ins: frozenset(self._adj.succ),
            Op.FILTER_CATEGORY: self._filter_category,
            Op.FILTER_ATTRIBUTE: self._filter_attribute,
            Op.FILTER_AFFORDANCE: self._filter_attribute,
            Op.MATCH_TEXT: self._match_text,
            Op.RELATE: self._relate,
            Op.RELATE_BETWEEN: self._between,
            Op.ARGMIN: self._rank,
            Op.ARGMAX: self._rank,
            Op.UNION: lambda i, s, ins: frozenset().union(*ins),
            Op.INTERSECT: lambda i, s, ins: frozenset.intersection(*ins),
            Op.DIFFERENCE: lambda i, s, ins: ins[0] - ins[1],
            Op.SUPPORT_CLOSURE: self._closure,
            Op.FALL_IF_REMOVED: lambda i, s, ins: self._fall(i, ins[0], paths),
            Op.COUNT: lambda i, s, ins: len(ins[0]),
            Op.EXISTS: lambda i, s, ins: bool(ins[0]),
        }
        return run_sets(self.scene_id, program, handlers, paths, self.name)

    def _filter_category(self, i: int, step: Step, ins: list[frozenset[int]]) -> RunValue:
        wanted = normalise_text(step.value or "")
        return frozenset(x for x in ins[0] if normalise_text(self._entity(x).category) == wanted)

    def _filter_attribute(self, i: int, step: Step, ins: list[frozenset[int]]) -> RunValue:
        key, value = attribute_filter(step.op.value, step.value or "", self.config)
        return frozenset(
            x
            for x in ins[0]
            if any(
                normalise_text(a.key) == key and normalise_text(a.value) == value
                for a in self._entity(x).attributes
            )
        )

    def _match_text(self, i: int, step: Step, ins: list[frozenset[int]]) -> RunValue:
        texts = {t for x in ins[0] for t in _texts(self._entity(x))}
        ranks = rank_texts(step.value or "", texts)
        keyed = []
        for x in ins[0]:
            best = [ranks[t] for t in _texts(self._entity(x)) if t in ranks]
            if best:
                keyed.append((min(best), x))
        return top_k(keyed, step.effective_k)

    def _relate(self, i: int, step: Step, ins: list[frozenset[int]]) -> RunValue:
        rel = step.relation
        assert rel is not None
        subjects, anchors = ins
        if rel.is_view_dependent:
            return self._view_relate(step, subjects, anchors)
        inverse = rel.inverse.value
        hits: set[int] = set()
        for a in anchors:
            hits.update(u for u, keys in self._adj.pred[a].items() if rel.value in keys)
            hits.update(v for v, keys in self._adj.succ[a].items() if inverse in keys)
        return subjects & frozenset(hits)

    def _view_relate(
        self, step: Step, subjects: frozenset[int], anchors: frozenset[int]
    ) -> RunValue:
        rel = step.relation
        assert rel is not None
        vp = step.viewpoint
        eye = (vp.eye[0], vp.eye[1]) if vp else (self._centre[0], self._centre[1])
        out = set()
        for s in subjects:
            sc = self._entity(s).centroid
            for a in anchors:
                ac = self._entity(a).centroid
                target = (vp.target[0], vp.target[1]) if vp else _xy(ac)
                if view_relation(PY, rel, _xy(sc), _xy(ac), eye, target):
                    out.add(s)
                    break
        return frozenset(out)

    def _between(self, i: int, step: Step, ins: list[frozenset[int]]) -> RunValue:
        subjects, firsts, seconds = ins
        ratio = self.config.between_lateral_ratio
        out = set()
        for s in subjects:
            sc = self._entity(s).centroid
            if any(
                between(
                    PY, _xy(sc), _xy(self._entity(a).centroid), _xy(self._entity(b).centroid), ratio
                )
                for a in firsts
                for b in seconds
            ):
                out.add(s)
        return frozenset(out)

    def _rank(self, i: int, step: Step, ins: list[frozenset[int]]) -> RunValue:
        metric = step.metric
        assert metric is not None
        sign = 1.0 if step.op is Op.ARGMIN else -1.0
        keyed: list[tuple[float, int]] = []
        for x in ins[0]:
            e = self._entity(x)
            flat = metric is Metric.HORIZONTAL_DISTANCE
            if not metric.is_distance:
                value = metric_value(PY, metric.value, e.centroid, e.bbox_min, e.bbox_max)
            elif len(ins) == 2:
                others = [
                    squared_distance(PY, e.centroid, self._entity(a).centroid, horizontal=flat)
                    for a in ins[1]
                    if a != x
                ]
                if not others:
                    continue
                value = min(others)
            else:
                value = squared_distance(PY, e.centroid, self._centre, horizontal=flat)
            keyed.append((sign * value, x))
        return top_k(keyed, step.effective_k)

    def _closure(self, i: int, step: Step, ins: list[frozenset[int]]) -> RunValue:
        seen: set[int] = set()
        frontier = list(ins[0])
        while frontier:
            node = frontier.pop()
            for upper in self._adj.sup_pred[node]:
                if upper not in seen:
                    seen.add(upper)
                    frontier.append(upper)
        return frozenset(seen)

    def _fall(self, i: int, removed: frozenset[int], paths: list[SupportPath]) -> RunValue:
        supporters = {x: set(lower) for x, lower in self._adj.sup_succ.items()}
        structural = [
            x for x in self._adj.succ if self.config.is_structural(self._entity(x).category)
        ]
        rounds = fall_rounds(removed, supporters, structural)
        paths.extend(support_paths(i, removed, rounds, supporters))
        return frozenset(rounds)


def _texts(e: Entity) -> tuple[str, ...]:
    return (e.category,) if e.caption is None else (e.category, e.caption)


def _xy(p: tuple[float, float, float]) -> tuple[float, float]:
    return (p[0], p[1])


def _scene_centre(graph: SceneGraph) -> tuple[float, float, float]:
    ents = graph.entities
    if not ents:
        return (0.0, 0.0, 0.0)
    lo = [min(e.bbox_min[i] for e in ents) for i in range(3)]
    hi = [max(e.bbox_max[i] for e in ents) for i in range(3)]
    x, y, z = (centre_coordinate(PY, lo[i], hi[i]) for i in range(3))
    return (x, y, z)
