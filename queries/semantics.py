"""The reference semantics of the query language, defined once for every executor.

Text matching
    * ``filter_category``: a member matches when its category equals ``value`` after
      :func:`normalise_text` on both (Unicode whitespace runs collapsed to one space, ends
      stripped, then ``str.casefold``). ``" Kitchen  Cabinet"`` matches ``"kitchen cabinet"``.
    * ``filter_attribute``: ``value`` is ``"key=value"`` (split at the first ``=``); a
      member matches when it has an attribute whose normalised key and value equal the
      normalised halves. ``filter_affordance``: the same with key ``affordance``.
    * ``match_text``: :func:`text_similarity` between ``value`` and each member's category
      and caption; a member scores its best text; members scoring 0 are dropped; the ``k``
      best are kept, ties broken by entity id.
    The SQL and SPARQL executors apply these rules in Python to the *distinct* stored
    categories / attribute pairs / captions of the scene (read from the database), and pass
    the exact stored strings that match (and, for ``match_text``, each text's rank) back to
    the database as a bound set; the database then selects the entities.

Geometry (world frame, scene units, ``z`` up; see :class:`Algebra`)
    * Scene centre: the centre of the union of all entity bounding boxes
      (``(min(min_x) + max(max_x)) * 0.5`` per axis), over the whole scene.
    * ``distance``: squared centroid distance ``dx*dx + dy*dy + dz*dz`` (ranking by the square
      ranks by the distance) to the nearest member of the reference set other than the
      entity itself; members with no such reference are dropped. Without a reference set:
      to the scene centre. ``horizontal_distance``: the same with ``dz`` left out.
      ``box_distance``: the squared distance to the nearest point of the reference member's
      bounding box from the entity's centroid ``c`` (per axis the gap
      ``relu(lo - c) + relu(c - hi)`` with ``relu(a) = (a + abs(a)) * 0.5``; 0 inside the
      box); to the scene centre without a reference set. See :func:`reference_distance`.
    * ``argmin`` / ``argmax``: sort by (metric ascending / descending, entity id ascending),
      keep the first ``k``. ``middle``: sort as ``argmin`` does and keep the ``(n + 1) / 2``-th
      of an odd number ``n`` of members, the ``n / 2``-th and ``(n / 2 + 1)``-th of an even
      number (none of none). ``rightward`` (:func:`metric_value`): ``d·(f.y, -f.x)`` with
      ``f = target - eye`` of the step's viewpoint and ``d = centroid - eye``; ``forward``:
      ``d·f``.
    * View-dependent relations (:func:`view_relation`), horizontal plane only: the observer
      looks from ``eye`` towards ``target`` (default: from the scene centre towards the anchor
      ``a``); with ``f = target - eye`` and ``d = s - a``, ``fwd = d·f`` and
      ``side = d·(f.y, -f.x)`` (``> 0``: to the observer's right). Each relation is a 90° sector
      around its direction: ``right_of``: ``side > 0`` and ``side >= |fwd|``;
      ``left_of``: ``side < 0`` and ``-side >= |fwd|``; ``behind``: ``fwd > 0`` and
      ``fwd > |side|``; ``in_front_of``: ``fwd < 0`` and ``-fwd > |side|``. On the diagonals the
      lateral relation wins; when ``f`` or ``d`` is zero no relation holds.
    * ``relate_between`` (:func:`between`), horizontal plane: with ``u = b - a`` and
      ``w = s - a``, ``s`` is between when its projection falls strictly inside the segment
      (``0 < w·u < u·u``) and its distance from the line ``ab`` is at most
      ``between_lateral_ratio`` times ``|ab|`` (``|w × u| <= ratio * u·u``).
    * ``segment_distance`` (:func:`segment_distance`), horizontal plane: ``argmin(S, A, B)``
      ranks each member by its smallest squared distance to a segment from a member of
      ``A`` to a member of ``B`` (the two distinct, neither the member itself); members
      with no such pair are dropped.
    Every formula is written once against :class:`Algebra` and evaluated on Python floats
    (networkx), as SQL expressions, or as SPARQL expressions, with the same operations in the
    same order, so IEEE-754 doubles give the same answers everywhere.

Support
    ``x`` rests on ``y`` when ``x supported_by y`` or ``y supports x`` is stored.
    ``support_closure(S)``: every ``x`` with a chain of one or more such edges from ``x`` down
    to a member of ``S`` (members of ``S`` are included only when they rest on ``S`` in turn).
    ``fall_if_removed(S)``: the least fixpoint of "``x`` falls when it has at least one
    supporter and all of them are removed (in ``S``) or fallen"; entities of the structural
    categories never fall; removed entities are not reported as fallen. Entities holding each
    other up in a support cycle stay up unless something outside the cycle removes all their
    support. :func:`support_paths` explains each fallen entity.

Stored relations
    ``relate(S, A, r)`` keeps ``s`` when ``s r a`` or ``a inverse(r) s`` is stored for some ``a``
    in ``A`` (so a builder may store either direction).

Sets
    ``coalesce(S1, S2, ...)``: the first input, in input order, that is non-empty (the empty
    set when all are). Over many scenes each scene chooses its own: its answer is that of a
    run on the scene alone.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from functools import lru_cache
from typing import TYPE_CHECKING, Generic, TypeVar

from graph_store.types import RelationType
from queries.errors import QueryValidationError

if TYPE_CHECKING:
    from queries.model import Viewpoint

N = TypeVar("N")  # a numeric expression
B = TypeVar("B")  # a boolean expression


@dataclass(frozen=True, slots=True)
class QueryConfig:
    """Tunable parameters of the semantics (defaults as documented in this module).

    Attributes:
        structural_categories: categories that never fall (compared normalised).
        between_lateral_ratio: how far from the line ``ab`` an entity between ``a`` and
            ``b`` may be, as a fraction of ``|ab|`` (dimensionless).
        affordance_key: the attribute key ``filter_affordance`` reads.
    """

    structural_categories: tuple[str, ...] = ("floor", "wall", "ceiling")
    between_lateral_ratio: float = 0.3
    affordance_key: str = "affordance"

    def __post_init__(self) -> None:
        ratio = self.between_lateral_ratio
        if isinstance(ratio, bool) or not isinstance(ratio, int | float) or not 0 < ratio < 1e6:
            raise QueryValidationError(
                f"QueryConfig.between_lateral_ratio must be in (0, 1e6), got {ratio!r}"
            )
        key = self.affordance_key
        if not isinstance(key, str) or not key.strip():
            raise QueryValidationError(
                f"QueryConfig.affordance_key must be a non-empty string, got {key!r}"
            )

    def is_structural(self, category: str) -> bool:
        return normalise_text(category) in {normalise_text(c) for c in self.structural_categories}


DEFAULT_CONFIG = QueryConfig()


# -- text --------------------------------------------------------------------------------


def normalise_text(text: str) -> str:
    """Whitespace runs collapsed to one space, ends stripped, casefolded."""
    return " ".join(text.split()).casefold()


def split_attribute(value: str) -> tuple[str, str] | None:
    """``"key=value"`` as its normalised halves; ``None`` when either half is empty."""
    key, sep, val = value.partition("=")
    key, val = normalise_text(key), normalise_text(val)
    if not sep or not key or not val:
        return None
    return key, val


@lru_cache(maxsize=4096)
def _trigrams(text: str) -> frozenset[str]:
    padded = "  " + text + " "
    return frozenset(padded[i : i + 3] for i in range(len(padded) - 2))


def text_similarity(query: str, text: str) -> float:
    """Similarity in ``[0, 1]``: 1 for equal normalised texts, otherwise 0.99 times the
    Dice coefficient of their character-trigram sets (padded with two leading spaces and
    one trailing space)."""
    a, b = normalise_text(query), normalise_text(text)
    if not a or not b:
        return 0.0
    if a == b:
        return 1.0
    ga, gb = _trigrams(a), _trigrams(b)
    return 0.99 * (2.0 * len(ga & gb) / (len(ga) + len(gb)))


def rank_texts(query: str, texts: Iterable[str]) -> dict[str, int]:
    """Dense rank (0 = most similar) of every text with a similarity above 0."""
    scores = {t: text_similarity(query, t) for t in set(texts)}
    levels = sorted({s for s in scores.values() if s > 0.0}, reverse=True)
    rank_of = {s: r for r, s in enumerate(levels)}
    return {t: rank_of[s] for t, s in scores.items() if s > 0.0}


def matching_categories(value: str, categories: Iterable[str]) -> list[str]:
    """The stored categories ``filter_category(value)`` selects, sorted."""
    wanted = normalise_text(value)
    return sorted({c for c in categories if normalise_text(c) == wanted})


def matching_attributes(
    key: str, value: str, pairs: Iterable[tuple[str, str]]
) -> list[tuple[str, str]]:
    """The stored ``(key, value)`` pairs an attribute filter selects (``key``, ``value``
    already normalised), sorted."""
    return sorted(
        {(k, v) for k, v in pairs if normalise_text(k) == key and normalise_text(v) == value}
    )


def attribute_filter(op: str, value: str, config: QueryConfig) -> tuple[str, str]:
    """The normalised ``(key, value)`` a ``filter_attribute`` / ``filter_affordance`` reads."""
    if op == "filter_affordance":
        return normalise_text(config.affordance_key), normalise_text(value)
    parts = split_attribute(value)
    if parts is None:  # validated programs never get here
        raise ValueError(f"not a key=value attribute filter: {value!r}")
    return parts


# -- geometry ----------------------------------------------------------------------------


class Algebra(ABC, Generic[N, B]):
    """The operations the geometric rules use; one subclass per executor.

    Formulas call these methods in a fixed order, so every backend performs the same
    IEEE-754 operations (``+``, ``-``, ``*``, ``/``, ``abs``, comparisons) on the same
    doubles. A formula divides only by a value it has checked is not zero (``select``).
    """

    @abstractmethod
    def const(self, value: float) -> N: ...
    @abstractmethod
    def add(self, a: N, b: N) -> N: ...
    @abstractmethod
    def sub(self, a: N, b: N) -> N: ...
    @abstractmethod
    def mul(self, a: N, b: N) -> N: ...
    @abstractmethod
    def div(self, a: N, b: N) -> N: ...
    @abstractmethod
    def neg(self, a: N) -> N: ...
    @abstractmethod
    def abs(self, a: N) -> N: ...
    @abstractmethod
    def lt(self, a: N, b: N) -> B: ...
    @abstractmethod
    def le(self, a: N, b: N) -> B: ...
    @abstractmethod
    def gt(self, a: N, b: N) -> B: ...
    @abstractmethod
    def ge(self, a: N, b: N) -> B: ...
    @abstractmethod
    def all(self, *conditions: B) -> B: ...
    @abstractmethod
    def select(self, condition: B, a: N, b: N) -> N:
        """``a`` where ``condition`` holds, else ``b`` (no arithmetic: the chosen double)."""


class PyAlgebra(Algebra[float, bool]):
    """The algebra on Python floats (the reference)."""

    def const(self, value: float) -> float:
        return float(value)

    def add(self, a: float, b: float) -> float:
        return a + b

    def sub(self, a: float, b: float) -> float:
        return a - b

    def mul(self, a: float, b: float) -> float:
        return a * b

    def div(self, a: float, b: float) -> float:
        return a / b

    def neg(self, a: float) -> float:
        return -a

    def abs(self, a: float) -> float:
        return abs(a)

    def lt(self, a: float, b: float) -> bool:
        return a < b

    def le(self, a: float, b: float) -> bool:
        return a <= b

    def gt(self, a: float, b: float) -> bool:
        return a > b

    def ge(self, a: float, b: float) -> bool:
        return a >= b

    def all(self, *conditions: bool) -> bool:
        return all(conditions)

    def select(self, condition: bool, a: float, b: float) -> float:
        return a if condition else b


PY = PyAlgebra()


def centre_coordinate(alg: Algebra[N, B], lowest: N, highest: N) -> N:
    """One axis of the scene centre from the smallest bbox min and largest bbox max."""
    return alg.mul(alg.add(lowest, highest), alg.const(0.5))


def squared_distance(
    alg: Algebra[N, B], p: tuple[N, N, N], q: tuple[N, N, N], *, horizontal: bool = False
) -> N:
    """``dx*dx + dy*dy + dz*dz`` between two points (``dx*dx + dy*dy`` when ``horizontal``)."""
    dx, dy = alg.sub(p[0], q[0]), alg.sub(p[1], q[1])
    planar = alg.add(alg.mul(dx, dx), alg.mul(dy, dy))
    if horizontal:
        return planar
    dz = alg.sub(p[2], q[2])
    return alg.add(planar, alg.mul(dz, dz))


#: The weight of the squared centroid distance in ``box_centroid_distance`` (square
#: metres per square metre): small enough that it orders only members whose squared box
#: distances differ by less than ``1e-9`` times their squared centroid distance (below
#: 0.1 mm apart in a 100 m scene), large enough to survive double rounding.
CENTROID_TIE_WEIGHT = 1e-9


def reference_distance(
    alg: Algebra[N, B],
    metric: str,
    p: tuple[N, N, N],
    centroid: tuple[N, N, N],
    lo: tuple[N, N, N],
    hi: tuple[N, N, N],
) -> N:
    """What a distance metric ranks ``p`` by against one reference member (its ``centroid``
    and bounding box ``lo``..``hi``; for the scene centre pass the centre as all three):
    ``distance`` and ``horizontal_distance`` by :func:`squared_distance` to the centroid,
    ``box_distance`` by the squared distance to the nearest point of the box,
    ``box_centroid_distance`` by that plus :data:`CENTROID_TIE_WEIGHT` times the squared
    centroid distance (inside the box, nearer the centroid is nearer);
    ``end_distance`` and ``corner_distance`` horizontally, to the middle of the nearest end
    (one of the two shorter edges) and to the nearest corner of the box's footprint (its
    ``x``-``y`` rectangle; a square's ends are its edges across ``x``).

    >>> box = ((0.5, 0.5, 0.5), (0.0, 0.0, 0.0), (1.0, 1.0, 1.0))
    >>> [reference_distance(PY, m, (3.0, 0.0, 0.5), *box)
    ...  for m in ("distance", "horizontal_distance", "box_distance")]
    [6.5, 6.5, 4.0]
    >>> inside = [reference_distance(PY, "box_centroid_distance", p, *box)
    ...           for p in ((0.5, 0.5, 0.9), (0.5, 0.5, 0.6))]  # both inside the box
    >>> inside[1] < inside[0] < 1e-9  # nearer the centroid is nearer
    True
    >>> table = ((1.0, 0.5, 0.4), (0.0, 0.0, 0.0), (2.0, 1.0, 0.8))  # long along x
    >>> [reference_distance(PY, m, p, *table)
    ...  for m in ("end_distance", "corner_distance") for p in ((2.5, 0.5, 0.4), (1.0, 1.5, 0.4))]
    [0.25, 2.0, 0.5, 1.25]
    """
    if metric == "distance":
        return squared_distance(alg, p, centroid)
    if metric == "horizontal_distance":
        return squared_distance(alg, p, centroid, horizontal=True)
    half = alg.const(0.5)
    if metric == "box_centroid_distance":
        tie = alg.mul(alg.const(CENTROID_TIE_WEIGHT), squared_distance(alg, p, centroid))
        return alg.add(reference_distance(alg, "box_distance", p, centroid, lo, hi), tie)
    if metric == "box_distance":
        squares = []
        for axis in range(3):
            below, above = alg.sub(lo[axis], p[axis]), alg.sub(p[axis], hi[axis])
            gap = alg.add(
                alg.mul(alg.add(below, alg.abs(below)), half),
                alg.mul(alg.add(above, alg.abs(above)), half),
            )
            squares.append(alg.mul(gap, gap))
        return alg.add(alg.add(squares[0], squares[1]), squares[2])
    if metric not in ("end_distance", "corner_distance"):
        raise ValueError(f"metric {metric!r} is not a distance")
    # per horizontal axis: how far p lies from the footprint's middle line along it, and
    # from its nearer edge across that axis (negative between the two edges)
    offs, edge = [], []
    for axis in (0, 1):
        mid = alg.mul(alg.add(lo[axis], hi[axis]), half)
        off = alg.abs(alg.sub(p[axis], mid))
        e = alg.sub(off, alg.mul(alg.sub(hi[axis], lo[axis]), half))
        offs.append(off)
        edge.append(alg.mul(e, e))
    if metric == "corner_distance":
        return alg.add(edge[0], edge[1])
    # the ends are the edges across the long axis; measured to the nearer one's midpoint
    middle = [alg.mul(off, off) for off in offs]
    long_x = alg.ge(alg.sub(hi[0], lo[0]), alg.sub(hi[1], lo[1]))
    return alg.select(long_x, alg.add(edge[0], middle[1]), alg.add(middle[0], edge[1]))


def metric_value(
    alg: Algebra[N, B],
    metric: str,
    centroid: tuple[N, N, N],
    lo: tuple[N, N, N],
    hi: tuple[N, N, N],
    view: tuple[tuple[N, N], tuple[N, N]] | None = None,
) -> N:
    """An entity's value for a non-distance metric (``x``, ``y``, ``z``, ``height``,
    ``length``, ``volume``, ``rightward``, ``forward``). ``rightward`` and ``forward`` need
    ``view``, ``(eye, target)`` (x, y): with ``f = target - eye`` and ``d = centroid - eye``,
    ``rightward`` is ``d·(f.y, -f.x)`` (``dx*fy - dy*fx``), larger to the observer's right,
    and ``forward`` is ``d·f`` (``dx*fx + dy*fy``), larger the farther ahead.

    >>> view = ((0.0, 0.0), (0.0, 2.0))  # at the origin, looking along +y
    >>> [metric_value(PY, m, (1.0, 3.0, 0.0), (0, 0, 0), (1, 1, 1), view)
    ...  for m in ("rightward", "forward")]
    [2.0, 6.0]
    >>> metric_value(PY, "length", (0.0, 0.0, 0.0), (0, 0, 0), (0.5, 2.0, 1.0))
    2.0
    """
    if metric in ("rightward", "forward"):
        if view is None:
            raise ValueError(f"metric {metric!r} needs a view (eye, target)")
        (ex, ey), (tx, ty) = view
        fx, fy = alg.sub(tx, ex), alg.sub(ty, ey)
        dx, dy = alg.sub(centroid[0], ex), alg.sub(centroid[1], ey)
        if metric == "forward":
            return alg.add(alg.mul(dx, fx), alg.mul(dy, fy))
        return alg.sub(alg.mul(dx, fy), alg.mul(dy, fx))
    if metric == "x":
        return centroid[0]
    if metric == "y":
        return centroid[1]
    if metric == "z":
        return centroid[2]
    if metric == "height":
        return alg.sub(hi[2], lo[2])
    if metric == "length":
        sx, sy = alg.sub(hi[0], lo[0]), alg.sub(hi[1], lo[1])
        return alg.select(alg.ge(sx, sy), sx, sy)
    if metric == "volume":
        sx, sy, sz = alg.sub(hi[0], lo[0]), alg.sub(hi[1], lo[1]), alg.sub(hi[2], lo[2])
        return alg.mul(alg.mul(sx, sy), sz)
    raise ValueError(f"metric {metric!r} has no per-entity value")


def view_consts(
    alg: Algebra[N, B], viewpoint: Viewpoint | None
) -> tuple[tuple[N, N], tuple[N, N]] | None:
    """A step's :class:`~queries.model.Viewpoint` as ``(eye, target)`` constants (x, y) of
    ``alg``, for :func:`metric_value`; ``None`` without one."""
    if viewpoint is None:
        return None
    eye, target = viewpoint.eye, viewpoint.target
    return (alg.const(eye[0]), alg.const(eye[1])), (alg.const(target[0]), alg.const(target[1]))


def view_relation(
    alg: Algebra[N, B],
    relation: RelationType,
    s: tuple[N, N],
    a: tuple[N, N],
    eye: tuple[N, N],
    target: tuple[N, N],
) -> B:
    """Whether ``s`` is ``relation`` of ``a`` seen from ``eye`` looking at ``target`` (x, y)."""
    fx, fy = alg.sub(target[0], eye[0]), alg.sub(target[1], eye[1])
    dx, dy = alg.sub(s[0], a[0]), alg.sub(s[1], a[1])
    fwd = alg.add(alg.mul(dx, fx), alg.mul(dy, fy))
    side = alg.sub(alg.mul(dx, fy), alg.mul(dy, fx))
    zero = alg.const(0.0)
    if relation is RelationType.RIGHT_OF:
        return alg.all(alg.gt(side, zero), alg.ge(side, alg.abs(fwd)))
    if relation is RelationType.LEFT_OF:
        return alg.all(alg.lt(side, zero), alg.ge(alg.neg(side), alg.abs(fwd)))
    if relation is RelationType.BEHIND:
        return alg.all(alg.gt(fwd, zero), alg.gt(fwd, alg.abs(side)))
    if relation is RelationType.IN_FRONT_OF:
        return alg.all(alg.lt(fwd, zero), alg.gt(alg.neg(fwd), alg.abs(side)))
    raise ValueError(f"{relation.value!r} is not a view-dependent relation")


def between(alg: Algebra[N, B], s: tuple[N, N], a: tuple[N, N], b: tuple[N, N], ratio: float) -> B:
    """Whether ``s`` lies between ``a`` and ``b`` in the horizontal plane (see module doc)."""
    ux, uy = alg.sub(b[0], a[0]), alg.sub(b[1], a[1])
    wx, wy = alg.sub(s[0], a[0]), alg.sub(s[1], a[1])
    dot = alg.add(alg.mul(wx, ux), alg.mul(wy, uy))
    l2 = alg.add(alg.mul(ux, ux), alg.mul(uy, uy))
    cross = alg.sub(alg.mul(wx, uy), alg.mul(wy, ux))
    zero = alg.const(0.0)
    return alg.all(
        alg.gt(dot, zero), alg.lt(dot, l2), alg.le(alg.abs(cross), alg.mul(alg.const(ratio), l2))
    )


def segment_distance(alg: Algebra[N, B], s: tuple[N, N], a: tuple[N, N], b: tuple[N, N]) -> N:
    """The squared horizontal distance from ``s`` to the segment from ``a`` to ``b`` (x, y):
    with ``u = b - a`` and ``w = s - a``, the nearest point is ``a + t u`` with
    ``t = w·u / u·u`` clamped to ``[0, 1]`` (``t = 0`` when ``a`` and ``b`` coincide), and
    the value is ``(w.x - t u.x)² + (w.y - t u.y)²``. For an entity between ``a`` and ``b``
    (:func:`between`) it is its squared offset from the line ``ab``: the smallest is the
    one most squarely between them ("the trash can between the desk and the door").

    >>> [segment_distance(PY, p, (0.0, 0.0), (4.0, 0.0)) for p in ((1.0, 2.0), (6.0, 1.0))]
    [4.0, 5.0]
    >>> segment_distance(PY, (3.0, 4.0), (0.0, 0.0), (0.0, 0.0))  # the ends coincide
    25.0
    """
    ux, uy = alg.sub(b[0], a[0]), alg.sub(b[1], a[1])
    wx, wy = alg.sub(s[0], a[0]), alg.sub(s[1], a[1])
    dot = alg.add(alg.mul(wx, ux), alg.mul(wy, uy))
    l2 = alg.add(alg.mul(ux, ux), alg.mul(uy, uy))
    zero, one = alg.const(0.0), alg.const(1.0)
    some = alg.gt(l2, zero)  # divided by 1 where not (every engine evaluates both arms)
    t = alg.select(some, alg.div(dot, alg.select(some, l2, one)), zero)
    t = alg.select(alg.lt(t, zero), zero, alg.select(alg.gt(t, one), one, t))
    dx, dy = alg.sub(wx, alg.mul(t, ux)), alg.sub(wy, alg.mul(t, uy))
    return alg.add(alg.mul(dx, dx), alg.mul(dy, dy))


# -- support -----------------------------------------------------------------------------


def fall_rounds(
    removed: Iterable[int],
    supporters: Mapping[int, Iterable[int]],
    structural: Iterable[int],
) -> dict[int, int]:
    """The reference fixpoint: the round (1, 2, ...) in which each entity falls.

    ``supporters[x]`` are the entities ``x`` rests on; ``structural`` never fall.
    """
    known = set(removed)
    never = set(structural)
    support = {x: frozenset(ys) for x, ys in supporters.items() if ys}
    rounds: dict[int, int] = {}
    current = 0
    while True:
        current += 1
        new = [x for x, ys in support.items() if x not in known and x not in never and ys <= known]
        if not new:
            return rounds
        for x in new:
            rounds[x] = current
        known.update(new)


@dataclass(frozen=True, slots=True, order=True)
class SupportPath:
    """Why one entity falls in a ``fall_if_removed`` step.

    Attributes:
        step: index of the ``fall_if_removed`` step.
        entity: the fallen entity's id.
        path: ``(entity, supporter, ..., removed)``: each id rests on the next (a stored
            ``supported_by`` / ``supports`` edge); the last is a removed entity. At each hop
            the supporter that fell earliest is taken (a removed one first), ties by id.
    """

    step: int
    entity: int
    path: tuple[int, ...]


def support_paths(
    step: int,
    removed: Iterable[int],
    rounds: Mapping[int, int],
    supporters: Mapping[int, Iterable[int]],
) -> tuple[SupportPath, ...]:
    """One :class:`SupportPath` per fallen entity, sorted by entity id."""
    removed_set = set(removed)

    def order(y: int) -> tuple[int, int]:
        return (0 if y in removed_set else rounds[y], y)

    out = []
    for x in sorted(rounds):
        path = [x]
        cur = x
        while cur not in removed_set:
            cur = min(supporters[cur], key=order)
            path.append(cur)
        out.append(SupportPath(step, x, tuple(path)))
    return tuple(out)
