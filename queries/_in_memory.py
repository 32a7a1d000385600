"""What the two in-memory executors share: every step on the entities themselves.

:class:`InMemoryExecutor` runs a program over a :class:`~graph_store.types.SceneGraph` held
in memory; how it walks the graph's edges (the relations, the support graph) is left to
its subclasses: :class:`queries.networkx_executor.NetworkxExecutor` (the reference, on
networkx graphs and algorithms) and :class:`queries.memory_executor.MemoryExecutor` (plain
dicts, no networkx import; the reasoner's default). Every rule is the one written in
:mod:`queries.semantics`.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

from graph_store.types import Entity, RelationType, SceneGraph
from queries._base import Executor, RunValue, middle, run_sets, top_k
from queries.model import GraphQuery, Op, Step
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
    reference_distance,
    segment_distance,
    support_paths,
    view_consts,
    view_relation,
)


class InMemoryExecutor(Executor):
    """Runs programs on an in-memory scene graph; subclasses walk its edges."""

    def __init__(self, graph: SceneGraph, config: QueryConfig = DEFAULT_CONFIG) -> None:
        super().__init__(graph.scene_id, config)
        self.graph = graph
        self._by_id: dict[int, Entity] = {e.id: e for e in graph.entities}
        self._centre = _scene_centre(graph)

    # -- the graph's edges, in the subclass's own structures ---------------------------------

    def _nodes(self) -> Iterable[int]:
        """Every entity id, in entity order."""
        raise NotImplementedError

    def _related(self, anchor: int, relation: RelationType) -> Iterable[int]:
        """The entities ``x`` with a stored ``x relation anchor`` edge, or the inverse edge
        ``anchor inverse x``."""
        raise NotImplementedError

    def _resting_on(self, entities: frozenset[int]) -> frozenset[int]:
        """The entities that rest, directly or through others, on any of ``entities``."""
        raise NotImplementedError

    def _supporters(self) -> Mapping[int, Iterable[int]]:
        """For each entity, the entities it rests on."""
        raise NotImplementedError

    # -- the steps ----------------------------------------------------------------------------

    def _entity(self, entity_id: int) -> Entity:
        return self._by_id[entity_id]

    def _execute(self, program: GraphQuery) -> QueryResult:
        paths: list[SupportPath] = []
        handlers: dict[Op, Any] = {
            Op.SCENE: lambda i, s, ins: frozenset(self._nodes()),
            Op.FILTER_CATEGORY: self._filter_category,
            Op.FILTER_ATTRIBUTE: self._filter_attribute,
            Op.FILTER_AFFORDANCE: self._filter_attribute,
            Op.MATCH_TEXT: self._match_text,
            Op.RELATE: self._relate,
            Op.RELATE_BETWEEN: self._between,
            Op.ARGMIN: self._rank,
            Op.ARGMAX: self._rank,
            Op.MIDDLE: self._rank,
            Op.UNION: lambda i, s, ins: frozenset().union(*ins),
            Op.INTERSECT: lambda i, s, ins: frozenset.intersection(*ins),
            Op.DIFFERENCE: lambda i, s, ins: ins[0] - ins[1],
            Op.COALESCE: lambda i, s, ins: next((x for x in ins if x), frozenset()),
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
        hits: set[int] = set()
        for a in anchors:
            hits.update(self._related(a, rel))
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
        sign = -1.0 if step.op is Op.ARGMAX else 1.0
        keyed: list[tuple[float, int]] = []
        reference = [(a, self._entity(a)) for a in ins[1]] if len(ins) >= 2 else []
        far = [(b, self._entity(b)) for b in ins[2]] if len(ins) == 3 else []
        for x in ins[0]:
            e = self._entity(x)
            if metric.is_segment:
                ends = [
                    segment_distance(PY, _xy(e.centroid), _xy(ra.centroid), _xy(rb.centroid))
                    for a, ra in reference
                    if a != x
                    for b, rb in far
                    if b not in (x, a)
                ]
                if not ends:
                    continue
                value = min(ends)
            elif not metric.is_distance:
                value = metric_value(
                    PY,
                    metric.value,
                    e.centroid,
                    e.bbox_min,
                    e.bbox_max,
                    view_consts(PY, step.viewpoint),
                )
            elif len(ins) == 2:
                others = [
                    reference_distance(
                        PY, metric.value, e.centroid, r.centroid, r.bbox_min, r.bbox_max
                    )
                    for a, r in reference
                    if a != x
                ]
                if not others:
                    continue
                value = min(others)
            else:
                c = self._centre
                value = reference_distance(PY, metric.value, e.centroid, c, c, c)
            keyed.append((sign * value, x))
        if step.op is Op.MIDDLE:
            return middle(keyed)
        return top_k(keyed, step.effective_k)

    def _closure(self, i: int, step: Step, ins: list[frozenset[int]]) -> RunValue:
        return self._resting_on(ins[0])

    def _fall(self, i: int, removed: frozenset[int], paths: list[SupportPath]) -> RunValue:
        supporters = self._supporters()
        structural = [
            x for x in self._nodes() if self.config.is_structural(self._entity(x).category)
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
