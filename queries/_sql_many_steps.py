"""SQL compilation of each op over many scenes at once (SQLAlchemy Core).

The multi-scene twin of :mod:`queries._sql_steps`: every step is a ``SELECT`` of
``(scene_id, id)`` rows instead of ``id`` rows of one scene, so a single statement answers
a program for every selected scene. Inputs are read as row values
(``(scene_id, id) IN (SELECT scene_id, id FROM sN)``), joins between two inputs match on
the scene, the scene centre is one row per scene, and the ops that keep the first
``k`` (``match_text``, ``argmin`` / ``argmax``) number their rows per scene with
``ROW_NUMBER() OVER (PARTITION BY scene_id ...)``; ``middle`` numbers them so and counts
them with ``COUNT(*) OVER (PARTITION BY scene_id)``, keeping each scene's middle row (two
of an even count). Text filters bind the stored strings they select among the selected
scenes' distinct strings: every rule of :mod:`queries.semantics` that picks strings looks
at one string at a time, and text ranks are only compared within a scene, so the strings
of other scenes change nothing.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Iterable, Sequence
from typing import Any

import sqlalchemy as sa
from sqlalchemy.engine import Connection

from graph_store import models as m
from graph_store.types import RelationType
from queries._sql_steps import (
    ATTR,
    NO_RANK,
    REL,
    SQL,
    Cond,
    E,
    in_the_middle,
    located,
    middle_numbers,
)
from queries.model import Op, Step
from queries.semantics import (
    QueryConfig,
    attribute_filter,
    between,
    centre_coordinate,
    matching_attributes,
    matching_categories,
    metric_value,
    rank_texts,
    reference_distance,
    segment_distance,
    view_consts,
    view_relation,
)

#: ``(scene id, entity id)``: an entity among many scenes.
Pair = tuple[str, int]
_PAIR_TYPE = sa.TupleType(sa.String(), sa.Integer())


def pairs_in(scene: Any, entity: Any, pairs: Iterable[Pair], name: str) -> Cond:
    """``(scene, entity)`` is one of ``pairs``, rendered inline (values read from the
    database; the literals are escaped by the dialect), so large sets do not run into the
    drivers' parameter limits."""
    rows = sorted(pairs)
    if not rows:
        return sa.false()
    param = sa.bindparam(name, rows, expanding=True, literal_execute=True, type_=_PAIR_TYPE)
    cond: Cond = sa.tuple_(scene, entity).in_(param)
    return cond


def scenes_in(column: Any, scene_ids: Sequence[str] | None, name: str = "scope") -> Cond:
    """``column`` is one of the selected scenes (``None``: every stored scene)."""
    if scene_ids is None:
        return sa.true()
    if not scene_ids:
        return sa.false()
    param: Any = sa.bindparam(name, sorted(scene_ids), expanding=True, literal_execute=True)
    cond: Cond = column.in_(param)
    return cond


class SqlManySteps:
    """Per-run compiler state over the selected scenes (``None``: all stored scenes)."""

    def __init__(
        self, conn: Connection, scene_ids: Sequence[str] | None, config: QueryConfig
    ) -> None:
        self.conn, self.scene_ids, self.config = conn, scene_ids, config
        self._categories: list[str] | None = None
        self._captions: list[str] | None = None
        self._attributes: list[tuple[str, str]] | None = None
        self._centre: Any = None
        self._support: Any = None
        self.whole: set[int] = set()  # steps whose result is every selected scene's entities

    def scope(self, column: Any) -> Cond:
        return scenes_in(column, self.scene_ids)

    # -- shared pieces -------------------------------------------------------------------

    def categories(self) -> list[str]:
        if self._categories is None:
            q = sa.select(E.c.category).where(self.scope(E.c.scene_id)).distinct()
            self._categories = list(self.conn.execute(q).scalars())
        return self._categories

    def captions(self) -> list[str]:
        if self._captions is None:
            q = (
                sa.select(E.c.caption)
                .where(self.scope(E.c.scene_id), E.c.caption.is_not(None))
                .distinct()
            )
            self._captions = list(self.conn.execute(q).scalars())
        return self._captions

    def attributes(self) -> list[tuple[str, str]]:
        if self._attributes is None:
            q = sa.select(ATTR.c.key, ATTR.c.value).where(self.scope(ATTR.c.scene_id))
            self._attributes = [(k, v) for k, v in self.conn.execute(q.distinct())]
        return self._attributes

    def centre(self) -> Any:
        """A CTE ``centre(scene_id, x, y, z)``: each selected scene's centre."""
        if self._centre is None:
            cols = [
                centre_coordinate(SQL, sa.func.min(lo), sa.func.max(hi)).label(axis)
                for axis, lo, hi in (
                    ("x", E.c.min_x, E.c.max_x),
                    ("y", E.c.min_y, E.c.max_y),
                    ("z", E.c.min_z, E.c.max_z),
                )
            ]
            self._centre = (
                sa.select(E.c.scene_id, *cols)
                .where(self.scope(E.c.scene_id))
                .group_by(E.c.scene_id)
                .cte("centre")
            )
        return self._centre

    def support(self) -> Any:
        """A CTE ``support(scene_id, upper, lower)``: ``upper`` rests on ``lower``."""
        if self._support is None:
            down = sa.select(
                REL.c.scene_id, REL.c.src.label("upper"), REL.c.dst.label("lower")
            ).where(self.scope(REL.c.scene_id), REL.c.type == RelationType.SUPPORTED_BY.value)
            up = sa.select(REL.c.scene_id, REL.c.dst, REL.c.src).where(
                self.scope(REL.c.scene_id), REL.c.type == RelationType.SUPPORTS.value
            )
            self._support = sa.union(down, up).cte("support")
        return self._support

    def support_edges(self, scene_ids: Iterable[str]) -> Any:
        """``(scene_id, upper, lower, category of upper)`` for every support edge of the
        given scenes (``upper`` rests on ``lower``; each edge once)."""
        chosen = sorted(scene_ids)
        down = sa.select(REL.c.scene_id, REL.c.src.label("upper"), REL.c.dst.label("lower")).where(
            REL.c.type == RelationType.SUPPORTED_BY.value,
            scenes_in(REL.c.scene_id, chosen, "fall_down"),
        )
        up = sa.select(REL.c.scene_id, REL.c.dst, REL.c.src).where(
            REL.c.type == RelationType.SUPPORTS.value,
            scenes_in(REL.c.scene_id, chosen, "fall_up"),
        )
        edges = sa.union(down, up).subquery("edges")
        return sa.select(edges.c.scene_id, edges.c.upper, edges.c.lower, E.c.category).join(
            E, sa.and_(E.c.scene_id == edges.c.scene_id, E.c.id == edges.c.upper)
        )

    def members(self, scene: Any, column: Any, step: int, cte: Any) -> Cond:
        """``(scene, column)`` is in the input set (a scope test for a whole-scene input)."""
        if step in self.whole:
            return self.scope(scene)
        cond: Cond = sa.tuple_(scene, column).in_(sa.select(cte.c.scene_id, cte.c.id))
        return cond

    # -- ops -----------------------------------------------------------------------------

    def scene(self) -> Any:
        return sa.select(E.c.scene_id, E.c.id).where(self.scope(E.c.scene_id))

    def filter_category(self, step: Step, src: tuple[int, Any]) -> Any:
        cats = matching_categories(step.value or "", self.categories())
        return sa.select(E.c.scene_id, E.c.id).where(
            E.c.category.in_(cats), self.members(E.c.scene_id, E.c.id, *src)
        )

    def filter_attribute(self, step: Step, src: tuple[int, Any]) -> Any:
        key, value = attribute_filter(step.op.value, step.value or "", self.config)
        by_key: dict[str, list[str]] = defaultdict(list)
        for k, v in matching_attributes(key, value, self.attributes()):
            by_key[k].append(v)
        cond = sa.or_(
            sa.false(),
            *(sa.and_(ATTR.c.key == k, ATTR.c.value.in_(vs)) for k, vs in by_key.items()),
        )
        return (
            sa.select(ATTR.c.scene_id, ATTR.c.entity_id.label("id"))
            .where(cond, self.members(ATTR.c.scene_id, ATTR.c.entity_id, *src))
            .distinct()
        )

    @staticmethod
    def _first_k(keyed: Any, order: Sequence[Any], k: int) -> Any:
        """The first ``k`` rows of each scene of ``keyed`` (``scene_id``, ``id``, keys)."""
        number = sa.func.row_number().over(partition_by=keyed.c.scene_id, order_by=order)
        ranked = sa.select(keyed.c.scene_id, keyed.c.id, number.label("n")).subquery("ranked")
        return sa.select(ranked.c.scene_id, ranked.c.id).where(ranked.c.n <= k)

    @staticmethod
    def _middle(keyed: Any, order: Sequence[Any]) -> Any:
        """The middle row of each scene of ``keyed`` (two of an even count) in ``order``."""
        numbers = middle_numbers(list(order), keyed.c.scene_id)
        ranked = sa.select(keyed.c.scene_id, keyed.c.id, *numbers).subquery("ranked")
        return sa.select(ranked.c.scene_id, ranked.c.id).where(in_the_middle(ranked))

    def match_text(self, step: Step, src: tuple[int, Any]) -> Any:
        ranks = rank_texts(step.value or "", [*self.categories(), *self.captions()])
        where = self.members(E.c.scene_id, E.c.id, *src)
        if not ranks:
            return sa.select(E.c.scene_id, E.c.id).where(where, sa.false())
        by_cat = sa.case(ranks, value=E.c.category, else_=NO_RANK)
        by_cap = sa.case(ranks, value=E.c.caption, else_=NO_RANK)
        best = sa.case((by_cat <= by_cap, by_cat), else_=by_cap)
        keyed = (
            sa.select(E.c.scene_id, E.c.id, best.label("v"))
            .where(where, best < NO_RANK)
            .subquery("keyed")
        )
        return self._first_k(keyed, [keyed.c.v, keyed.c.id], step.effective_k)

    def relate(self, step: Step, subj: tuple[int, Any], anchor: tuple[int, Any]) -> Any:
        rel = step.relation
        assert rel is not None
        if rel.is_view_dependent:
            return self._view_relate(step, rel, subj, anchor)
        forward = sa.select(REL.c.scene_id, REL.c.src.label("id")).where(
            REL.c.type == rel.value,
            self.members(REL.c.scene_id, REL.c.dst, *anchor),
            self.members(REL.c.scene_id, REL.c.src, *subj),
        )
        backward = sa.select(REL.c.scene_id, REL.c.dst).where(
            REL.c.type == rel.inverse.value,
            self.members(REL.c.scene_id, REL.c.src, *anchor),
            self.members(REL.c.scene_id, REL.c.dst, *subj),
        )
        return sa.union_all(forward, backward)  # may repeat rows; readers allow for it

    def _view_relate(
        self, step: Step, rel: RelationType, subj: tuple[int, Any], anchor: tuple[int, Any]
    ) -> Any:
        s, a = E.alias("s"), E.alias("a")
        vp = step.viewpoint
        joined = s.join(a, a.c.scene_id == s.c.scene_id)
        eye: tuple[Any, Any]
        target: tuple[Any, Any]
        if vp is None:
            c = self.centre()
            eye, target = (c.c.x, c.c.y), (a.c.cx, a.c.cy)
            joined = joined.join(c, c.c.scene_id == s.c.scene_id)
        else:
            eye = (SQL.const(vp.eye[0]), SQL.const(vp.eye[1]))
            target = (SQL.const(vp.target[0]), SQL.const(vp.target[1]))
        cond = view_relation(SQL, rel, (s.c.cx, s.c.cy), (a.c.cx, a.c.cy), eye, target)
        return (
            sa.select(s.c.scene_id, s.c.id)
            .distinct()
            .select_from(joined)
            .where(
                self.members(s.c.scene_id, s.c.id, *subj),
                self.members(a.c.scene_id, a.c.id, *anchor),
                cond,
            )
        )

    def relate_between(self, step: Step, *inputs: tuple[int, Any]) -> Any:
        s, a, b = E.alias("s"), E.alias("a"), E.alias("b")
        cond = between(
            SQL,
            (s.c.cx, s.c.cy),
            (a.c.cx, a.c.cy),
            (b.c.cx, b.c.cy),
            self.config.between_lateral_ratio,
        )
        where = [a.c.scene_id == s.c.scene_id, b.c.scene_id == s.c.scene_id] + [
            self.members(t.c.scene_id, t.c.id, *src)
            for t, src in zip((s, a, b), inputs, strict=True)
        ]
        return sa.select(s.c.scene_id, s.c.id).distinct().where(*where, cond)

    def rank(self, step: Step, *inputs: tuple[int, Any]) -> Any:
        metric = step.metric
        assert metric is not None
        s = E.alias("s")
        centroid = (s.c.cx, s.c.cy, s.c.cz)
        base = [self.members(s.c.scene_id, s.c.id, *inputs[0])]
        if metric.is_segment:
            a, b = E.alias("a"), E.alias("b")
            d = segment_distance(SQL, (s.c.cx, s.c.cy), (a.c.cx, a.c.cy), (b.c.cx, b.c.cy))
            distinct = [a.c.id != s.c.id, b.c.id != s.c.id, b.c.id != a.c.id]
            keyed = (
                sa.select(s.c.scene_id, s.c.id, sa.func.min(d).label("v"))
                .where(*base, a.c.scene_id == s.c.scene_id, b.c.scene_id == s.c.scene_id)
                .where(self.members(a.c.scene_id, a.c.id, *inputs[1]))
                .where(self.members(b.c.scene_id, b.c.id, *inputs[2]))
                .where(*distinct)
                .group_by(s.c.scene_id, s.c.id)
            )
        elif not metric.is_distance:
            lo, hi = (s.c.min_x, s.c.min_y, s.c.min_z), (s.c.max_x, s.c.max_y, s.c.max_z)
            value = metric_value(
                SQL, metric.value, centroid, lo, hi, view_consts(SQL, step.viewpoint)
            )
            keyed = sa.select(s.c.scene_id, s.c.id, value.label("v")).where(*base)
        elif len(inputs) == 2:
            a = E.alias("a")
            d = reference_distance(SQL, metric.value, centroid, *located(a))
            keyed = (
                sa.select(s.c.scene_id, s.c.id, sa.func.min(d).label("v"))
                .where(*base, a.c.scene_id == s.c.scene_id, a.c.id != s.c.id)
                .where(self.members(a.c.scene_id, a.c.id, *inputs[1]))
                .group_by(s.c.scene_id, s.c.id)
            )
        else:
            c = self.centre()
            point = (c.c.x, c.c.y, c.c.z)
            d = reference_distance(SQL, metric.value, centroid, point, point, point)
            keyed = (
                sa.select(s.c.scene_id, s.c.id, d.label("v"))
                .select_from(s.join(c, c.c.scene_id == s.c.scene_id))
                .where(*base)
            )
        sub = keyed.subquery("keyed")
        order = sub.c.v.desc() if step.op is Op.ARGMAX else sub.c.v.asc()
        if step.op is Op.MIDDLE:
            return self._middle(sub, [order, sub.c.id])
        return self._first_k(sub, [order, sub.c.id], step.effective_k)

    def set_op(self, op: Op, inputs: list[tuple[int, Any]]) -> Any:
        ctes = [cte for _, cte in inputs]
        if op is Op.UNION:
            return sa.union(*(sa.select(c.c.scene_id, c.c.id) for c in ctes))
        if op is Op.COALESCE:
            # each input's rows of a scene when every earlier input is empty in that scene
            return sa.union_all(
                *(
                    sa.select(c.c.scene_id, c.c.id).where(
                        *(self._none_in(p, c.c.scene_id) for p in ctes[:n])
                    )
                    for n, c in enumerate(ctes)
                )
            )
        head = ctes[0]
        first = sa.select(head.c.scene_id, head.c.id)
        row = sa.tuple_(head.c.scene_id, head.c.id)
        if op is Op.INTERSECT:
            return first.where(*(row.in_(sa.select(c.c.scene_id, c.c.id)) for c in ctes[1:]))
        return first.where(row.not_in(sa.select(ctes[1].c.scene_id, ctes[1].c.id)))

    @staticmethod
    def _none_in(cte: Any, scene: Any) -> Cond:
        """``cte`` has no row of scene ``scene`` (read under an alias, so that an input given
        twice is not correlated with itself)."""
        other = cte.alias()
        cond: Cond = ~sa.exists(sa.select(other.c.id).where(other.c.scene_id == scene))
        return cond

    def support_closure(self, name: str, src: tuple[int, Any]) -> Any:
        """A recursive CTE: everything resting on the input, through one or more edges."""
        sup = self.support()
        seed = sa.select(sup.c.scene_id, sup.c.upper.label("id")).where(
            self.members(sup.c.scene_id, sup.c.lower, *src)
        )
        closure = seed.cte(name, recursive=True)
        return closure.union(
            sa.select(sup.c.scene_id, sup.c.upper).where(
                sup.c.scene_id == closure.c.scene_id, sup.c.lower == closure.c.id
            )
        )

    def fallen(self, pairs: Iterable[Pair], name: str) -> Any:
        """The entities ``pairs`` (a ``fall_if_removed`` result) as a step."""
        return sa.select(E.c.scene_id, E.c.id).where(pairs_in(E.c.scene_id, E.c.id, pairs, name))

    def selected_scenes(self) -> Any:
        """``SELECT id FROM scenes`` of the selected scenes."""
        return sa.select(m.scenes.c.id).where(self.scope(m.scenes.c.id))
