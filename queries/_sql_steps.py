"""SQL compilation of each op: one CTE per step over the store tables (SQLAlchemy Core).

Every step becomes a ``SELECT`` with a single ``id`` column, reading its inputs' CTEs and
the ``entities`` / ``entity_attributes`` / ``relations`` rows of one scene. Geometric
predicates come from :mod:`queries.semantics` through :class:`SqlAlgebra`; the strings that
text filters select are worked out in Python from the scene's distinct stored strings and
bound as parameters (see the semantics module). ``argmin`` / ``argmax`` order their
candidates' ``(metric, id)`` rows and keep the first ``k`` (``LIMIT``); ``middle`` numbers
the rows in ``argmin``'s order (``ROW_NUMBER() OVER``), counts them (``COUNT(*) OVER ()``)
and keeps the middle one (two of an even count).
"""

from __future__ import annotations

from collections import defaultdict
from typing import Any

import sqlalchemy as sa
from sqlalchemy.engine import Connection
from sqlalchemy.sql.elements import BinaryExpression, ColumnElement

from graph_store import models as m
from graph_store.types import RelationType
from queries.model import Op, Step
from queries.semantics import (
    Algebra,
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

E, ATTR, REL = m.entities, m.entity_attributes, m.relations
Num = ColumnElement[Any]
Cond = ColumnElement[bool]
#: Rank given to texts that do not match in ``match_text`` (larger than any real rank).
NO_RANK = 2_000_000_000


def located(t: Any) -> tuple[tuple[Any, Any, Any], tuple[Any, Any, Any], tuple[Any, Any, Any]]:
    """An entities table's (or alias's) centroid, box minimum and box maximum columns."""
    c = t.c
    return (c.cx, c.cy, c.cz), (c.min_x, c.min_y, c.min_z), (c.max_x, c.max_y, c.max_z)


class SqlAlgebra(Algebra[Num, Cond]):
    """The semantics' algebra as SQL expressions (doubles on SQLite and PostgreSQL).

    SQL renders ``a + (b + c)`` as ``a + b + c``; a right operand that is itself a binary
    expression is wrapped in ``CAST(... AS DOUBLE)`` so the evaluation order is kept.
    """

    @staticmethod
    def _keep(expr: Num) -> Num:
        return sa.cast(expr, sa.Double()) if isinstance(expr, BinaryExpression) else expr

    def const(self, value: float) -> Num:
        return sa.literal(float(value), sa.Double())

    def add(self, a: Num, b: Num) -> Num:
        return a + self._keep(b)

    def sub(self, a: Num, b: Num) -> Num:
        return a - self._keep(b)

    def mul(self, a: Num, b: Num) -> Num:
        return a * self._keep(b)

    def div(self, a: Num, b: Num) -> Num:
        return a / self._keep(b)

    def neg(self, a: Num) -> Num:
        return -self._keep(a)

    def abs(self, a: Num) -> Num:
        return sa.func.abs(a, type_=sa.Double())

    def lt(self, a: Num, b: Num) -> Cond:
        return a < b

    def le(self, a: Num, b: Num) -> Cond:
        return a <= b

    def gt(self, a: Num, b: Num) -> Cond:
        return a > b

    def ge(self, a: Num, b: Num) -> Cond:
        return a >= b

    def all(self, *conditions: Cond) -> Cond:
        return sa.and_(*conditions)

    def select(self, condition: Cond, a: Num, b: Num) -> Num:
        return sa.case((condition, a), else_=b)


SQL = SqlAlgebra()


def compile_shared(c: Any, name: str, step: Step, src: list[tuple[int, Any]]) -> Any | None:
    """The CTE ``name`` of ``step`` from its inputs ``src`` ((index, CTE) pairs) for the ops
    that the one-scene and the many-scene compilers (``c``: their step builders, which
    share these methods) write alike; ``None`` for ``scene``, ``fall_if_removed``,
    ``count`` and ``exists``, which each executor compiles its own way."""
    op = step.op
    if op is Op.FILTER_CATEGORY:
        return c.filter_category(step, src[0]).cte(name)
    if op in (Op.FILTER_ATTRIBUTE, Op.FILTER_AFFORDANCE):
        return c.filter_attribute(step, src[0]).cte(name)
    if op is Op.MATCH_TEXT:
        return c.match_text(step, src[0]).cte(name)
    if op is Op.RELATE:
        return c.relate(step, src[0], src[1]).cte(name)
    if op is Op.RELATE_BETWEEN:
        return c.relate_between(step, *src).cte(name)
    if op in (Op.ARGMIN, Op.ARGMAX, Op.MIDDLE):
        return c.rank(step, *src).cte(name)
    if op in (Op.UNION, Op.INTERSECT, Op.DIFFERENCE, Op.COALESCE):
        return c.set_op(op, src).cte(name)
    if op is Op.SUPPORT_CLOSURE:
        return c.support_closure(name, src[0])
    return None


def middle_numbers(order: list[Any], partition: Any = None) -> tuple[Num, Num]:
    """``r``: each row's place in ``order`` (from 1), and ``n``: the number of rows (both
    within ``partition`` when given), for :func:`in_the_middle`."""
    place = sa.func.row_number().over(partition_by=partition, order_by=order)
    count = sa.func.count().over(partition_by=partition)
    return place.label("r"), count.label("n")


def in_the_middle(ranked: Any) -> Cond:
    """The row of ``ranked`` (with the columns of :func:`middle_numbers`) in the middle:
    ``0 <= 2r - n <= 2`` holds for ``r = (n + 1) / 2`` of an odd ``n`` and for ``r = n / 2``
    and ``n / 2 + 1`` of an even one."""
    cond: Cond = (ranked.c.r * 2 - ranked.c.n).between(0, 2)
    return cond


def ids_literal(ids: set[int] | frozenset[int] | list[int], name: str) -> Any:
    """A list of entity ids rendered inline (integers from the database, never user text),
    so large sets do not run into the drivers' parameter limits."""
    return sa.bindparam(name, sorted(ids), expanding=True, literal_execute=True)


class SqlSteps:
    """Per-run compiler state: the scene, lazily read distinct strings, shared CTEs."""

    def __init__(self, conn: Connection, scene_id: str, config: QueryConfig) -> None:
        self.conn, self.scene_id, self.config = conn, scene_id, config
        self._categories: list[str] | None = None
        self._captions: list[str] | None = None
        self._attributes: list[tuple[str, str]] | None = None
        self._centre: Any = None
        self._support: Any = None
        self.whole: set[int] = set()  # steps whose result is the whole scene

    # -- shared pieces -------------------------------------------------------------------

    def categories(self) -> list[str]:
        if self._categories is None:
            q = sa.select(E.c.category).where(E.c.scene_id == self.scene_id).distinct()
            self._categories = list(self.conn.execute(q).scalars())
        return self._categories

    def captions(self) -> list[str]:
        if self._captions is None:
            q = (
                sa.select(E.c.caption)
                .where(E.c.scene_id == self.scene_id, E.c.caption.is_not(None))
                .distinct()
            )
            self._captions = list(self.conn.execute(q).scalars())
        return self._captions

    def attributes(self) -> list[tuple[str, str]]:
        if self._attributes is None:
            q = sa.select(ATTR.c.key, ATTR.c.value).where(ATTR.c.scene_id == self.scene_id)
            self._attributes = [(k, v) for k, v in self.conn.execute(q.distinct())]
        return self._attributes

    def centre(self) -> Any:
        """A one-row CTE ``centre(x, y, z)``: the scene centre."""
        if self._centre is None:
            cols = [
                centre_coordinate(SQL, sa.func.min(lo), sa.func.max(hi)).label(axis)
                for axis, lo, hi in (
                    ("x", E.c.min_x, E.c.max_x),
                    ("y", E.c.min_y, E.c.max_y),
                    ("z", E.c.min_z, E.c.max_z),
                )
            ]
            self._centre = sa.select(*cols).where(E.c.scene_id == self.scene_id).cte("centre")
        return self._centre

    def support(self) -> Any:
        """A CTE ``support(upper, lower)``: ``upper`` rests on ``lower``."""
        if self._support is None:
            down = sa.select(REL.c.src.label("upper"), REL.c.dst.label("lower")).where(
                REL.c.scene_id == self.scene_id, REL.c.type == RelationType.SUPPORTED_BY.value
            )
            up = sa.select(REL.c.dst, REL.c.src).where(
                REL.c.scene_id == self.scene_id, REL.c.type == RelationType.SUPPORTS.value
            )
            self._support = sa.union(down, up).cte("support")
        return self._support

    def resting_on(self, lower: Any) -> Any:
        """Ids resting directly on one of ``lower`` (an id list), possibly repeated."""
        down = sa.select(REL.c.src.label("id")).where(
            REL.c.scene_id == self.scene_id,
            REL.c.type == RelationType.SUPPORTED_BY.value,
            REL.c.dst.in_(lower),
        )
        up = sa.select(REL.c.dst).where(
            REL.c.scene_id == self.scene_id,
            REL.c.type == RelationType.SUPPORTS.value,
            REL.c.src.in_(lower),
        )
        return sa.union_all(down, up)

    def held_outside(self, upper: Any, known: Any) -> Cond:
        """``upper`` rests on something not in ``known`` (an id list)."""
        r = REL.alias("held")
        down = sa.exists(
            sa.select(r.c.src).where(
                r.c.scene_id == self.scene_id,
                r.c.src == upper,
                r.c.type == RelationType.SUPPORTED_BY.value,
                r.c.dst.not_in(known),
            )
        )
        r2 = REL.alias("held_up")
        up = sa.exists(
            sa.select(r2.c.dst).where(
                r2.c.scene_id == self.scene_id,
                r2.c.dst == upper,
                r2.c.type == RelationType.SUPPORTS.value,
                r2.c.src.not_in(known),
            )
        )
        return sa.or_(down, up)

    def supporter_edges(self, uppers: Any) -> Any:
        """``(upper, lower)`` for every support edge from one of ``uppers`` (an id list)."""
        down = sa.select(REL.c.src, REL.c.dst).where(
            REL.c.scene_id == self.scene_id,
            REL.c.type == RelationType.SUPPORTED_BY.value,
            REL.c.src.in_(uppers),
        )
        up = sa.select(REL.c.dst, REL.c.src).where(
            REL.c.scene_id == self.scene_id,
            REL.c.type == RelationType.SUPPORTS.value,
            REL.c.dst.in_(uppers),
        )
        return sa.union(down, up)

    def members(self, column: Any, step: int, cte: Any) -> Cond:
        """``column`` is in the input set (always true for a whole-scene input)."""
        if step in self.whole:
            return sa.true()
        cond: Cond = column.in_(sa.select(cte.c.id))
        return cond

    def entity(self, name: str) -> Any:
        return E.alias(name)

    # -- ops -----------------------------------------------------------------------------

    def scene(self) -> Any:
        return sa.select(E.c.id).where(E.c.scene_id == self.scene_id)

    def filter_category(self, step: Step, src: tuple[int, Any]) -> Any:
        cats = matching_categories(step.value or "", self.categories())
        return sa.select(E.c.id).where(
            E.c.scene_id == self.scene_id, E.c.category.in_(cats), self.members(E.c.id, *src)
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
            sa.select(ATTR.c.entity_id.label("id"))
            .where(ATTR.c.scene_id == self.scene_id, cond)
            .where(self.members(ATTR.c.entity_id, *src))
            .distinct()
        )

    def match_text(self, step: Step, src: tuple[int, Any]) -> Any:
        ranks = rank_texts(step.value or "", [*self.categories(), *self.captions()])
        base = sa.select(E.c.id).where(E.c.scene_id == self.scene_id, self.members(E.c.id, *src))
        if not ranks:
            return base.where(sa.false())
        by_cat = sa.case(ranks, value=E.c.category, else_=NO_RANK)
        by_cap = sa.case(ranks, value=E.c.caption, else_=NO_RANK)
        best = sa.case((by_cat <= by_cap, by_cat), else_=by_cap)
        return base.where(best < NO_RANK).order_by(best, E.c.id).limit(step.effective_k)

    def relate(self, step: Step, subj: tuple[int, Any], anchor: tuple[int, Any]) -> Any:
        rel = step.relation
        assert rel is not None
        if rel.is_view_dependent:
            return self._view_relate(step, rel, subj, anchor)
        forward = sa.select(REL.c.src.label("id")).where(
            REL.c.scene_id == self.scene_id,
            REL.c.type == rel.value,
            self.members(REL.c.dst, *anchor),
            self.members(REL.c.src, *subj),
        )
        backward = sa.select(REL.c.dst).where(
            REL.c.scene_id == self.scene_id,
            REL.c.type == rel.inverse.value,
            self.members(REL.c.src, *anchor),
            self.members(REL.c.dst, *subj),
        )
        return sa.union_all(forward, backward)  # may repeat ids; readers allow for it

    def _view_relate(
        self, step: Step, rel: RelationType, subj: tuple[int, Any], anchor: tuple[int, Any]
    ) -> Any:
        s, a = self.entity("s"), self.entity("a")
        vp = step.viewpoint
        query = sa.select(s.c.id).distinct()
        if vp is None:
            c = self.centre()
            eye, target = (c.c.x, c.c.y), (a.c.cx, a.c.cy)
            query = query.select_from(s.join(a, sa.true()).join(c, sa.true()))
        else:
            eye = (SQL.const(vp.eye[0]), SQL.const(vp.eye[1]))
            target = (SQL.const(vp.target[0]), SQL.const(vp.target[1]))
        cond = view_relation(SQL, rel, (s.c.cx, s.c.cy), (a.c.cx, a.c.cy), eye, target)
        return query.where(
            s.c.scene_id == self.scene_id,
            a.c.scene_id == self.scene_id,
            self.members(s.c.id, *subj),
            self.members(a.c.id, *anchor),
            cond,
        )

    def relate_between(self, step: Step, *inputs: tuple[int, Any]) -> Any:
        s, a, b = self.entity("s"), self.entity("a"), self.entity("b")
        cond = between(
            SQL,
            (s.c.cx, s.c.cy),
            (a.c.cx, a.c.cy),
            (b.c.cx, b.c.cy),
            self.config.between_lateral_ratio,
        )
        where = [t.c.scene_id == self.scene_id for t in (s, a, b)] + [
            self.members(t.c.id, *src) for t, src in zip((s, a, b), inputs, strict=True)
        ]
        return sa.select(s.c.id).distinct().where(*where, cond)

    def rank(self, step: Step, *inputs: tuple[int, Any]) -> Any:
        metric = step.metric
        assert metric is not None
        s = self.entity("s")
        centroid = (s.c.cx, s.c.cy, s.c.cz)
        base = [s.c.scene_id == self.scene_id, self.members(s.c.id, *inputs[0])]
        if metric.is_segment:
            a, b = self.entity("a"), self.entity("b")
            d = segment_distance(SQL, (s.c.cx, s.c.cy), (a.c.cx, a.c.cy), (b.c.cx, b.c.cy))
            distinct = [a.c.id != s.c.id, b.c.id != s.c.id, b.c.id != a.c.id]
            keyed = (
                sa.select(s.c.id, sa.func.min(d).label("v"))
                .where(*base, a.c.scene_id == self.scene_id, b.c.scene_id == self.scene_id)
                .where(self.members(a.c.id, *inputs[1]), self.members(b.c.id, *inputs[2]))
                .where(*distinct)
                .group_by(s.c.id)
            )
        elif not metric.is_distance:
            lo, hi = (s.c.min_x, s.c.min_y, s.c.min_z), (s.c.max_x, s.c.max_y, s.c.max_z)
            keyed = sa.select(
                s.c.id,
                metric_value(
                    SQL, metric.value, centroid, lo, hi, view_consts(SQL, step.viewpoint)
                ).label("v"),
            ).where(*base)
        elif len(inputs) == 2:
            a = self.entity("a")
            d = reference_distance(SQL, metric.value, centroid, *located(a))
            keyed = (
                sa.select(s.c.id, sa.func.min(d).label("v"))
                .where(*base, a.c.scene_id == self.scene_id, a.c.id != s.c.id)
                .where(self.members(a.c.id, *inputs[1]))
                .group_by(s.c.id)
            )
        else:
            c = self.centre()
            point = (c.c.x, c.c.y, c.c.z)
            d = reference_distance(SQL, metric.value, centroid, point, point, point)
            keyed = sa.select(s.c.id, d.label("v")).select_from(s.join(c, sa.true())).where(*base)
        sub = keyed.subquery("keyed")
        order = sub.c.v.desc() if step.op is Op.ARGMAX else sub.c.v.asc()
        if step.op is Op.MIDDLE:
            ranked = sa.select(sub.c.id, *middle_numbers([order, sub.c.id])).subquery("ranked")
            return sa.select(ranked.c.id).where(in_the_middle(ranked))
        return sa.select(sub.c.id).order_by(order, sub.c.id).limit(step.effective_k)

    def set_op(self, op: Op, inputs: list[tuple[int, Any]]) -> Any:
        ctes = [cte for _, cte in inputs]
        if op is Op.UNION:
            return sa.union(*(sa.select(c.c.id) for c in ctes))
        if op is Op.COALESCE:
            # each input's rows when every earlier input is empty
            return sa.union_all(
                *(
                    sa.select(c.c.id).where(*(self._empty(p) for p in ctes[:n]))
                    for n, c in enumerate(ctes)
                )
            )
        first = sa.select(ctes[0].c.id)
        if op is Op.INTERSECT:
            return first.where(*(ctes[0].c.id.in_(sa.select(c.c.id)) for c in ctes[1:]))
        return first.where(ctes[0].c.id.not_in(sa.select(ctes[1].c.id)))

    @staticmethod
    def _empty(cte: Any) -> Cond:
        """``cte`` has no row (read under an alias, so that an input given twice is not
        correlated with itself)."""
        other = cte.alias()
        cond: Cond = ~sa.exists(sa.select(other.c.id))
        return cond

    def support_closure(self, name: str, src: tuple[int, Any]) -> Any:
        """A recursive CTE: everything resting on the input, through one or more edges."""
        sup = self.support()
        seed = sa.select(sup.c.upper.label("id")).where(self.members(sup.c.lower, *src))
        closure = seed.cte(name, recursive=True)
        return closure.union(sa.select(sup.c.upper).where(sup.c.lower == closure.c.id))
