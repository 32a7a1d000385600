"""The reference semantics (queries.semantics): text rules, geometric rules on hand-made
cases, and the same formulas evaluated by SQLite, Oxigraph and rdflib giving the same
IEEE-754 answers as Python; SPARQL literal escaping."""

from __future__ import annotations

from fractions import Fraction

import pyoxigraph as ox
import pytest
import rdflib
import sqlalchemy as sa
from hypothesis import given, settings
from hypothesis import strategies as st

from graph_store.types import RelationType
from queries._sparql_steps import SPARQL, double, literal
from queries._sql_steps import SQL
from queries.semantics import (
    CENTROID_TIE_WEIGHT,
    PY,
    QueryConfig,
    between,
    normalise_text,
    rank_texts,
    reference_distance,
    segment_distance,
    split_attribute,
    squared_distance,
    text_similarity,
    view_relation,
)

VIEW = [RelationType.LEFT_OF, RelationType.RIGHT_OF, RelationType.IN_FRONT_OF, RelationType.BEHIND]


def test_text_rules() -> None:
    assert normalise_text("  Kitchen \t\n CABINET ") == "kitchen cabinet"
    assert normalise_text("Straße") == "strasse"  # casefold, not lower
    assert split_attribute(" Color = Light  Red ") == ("color", "light red")
    assert split_attribute("a=b=c") == ("a", "b=c")
    assert split_attribute("color") is None and split_attribute("=red") is None
    assert text_similarity("Sink", " sink ") == 1.0
    assert 0 < text_similarity("toaster", "toaster oven") < 0.99
    assert text_similarity("cup", "zzz") == 0.0
    assert rank_texts("toaster", ["toaster oven", "toaster", "sink", "Toaster"]) == {
        "toaster": 0,
        "Toaster": 0,
        "toaster oven": 1,
    }
    config = QueryConfig(structural_categories=("Floor", "wall"))
    assert config.is_structural(" FLOOR") and not config.is_structural("floor mat")


@pytest.mark.parametrize(
    ("s", "expected"),
    [
        ((1.0, 1.0), RelationType.LEFT_OF),  # looking along +x from the origin at (1, 0)
        ((1.0, -1.0), RelationType.RIGHT_OF),
        ((2.0, 0.0), RelationType.BEHIND),
        ((0.5, 0.0), RelationType.IN_FRONT_OF),
        ((2.0, 1.0), RelationType.LEFT_OF),  # on the diagonal the lateral relation wins
        ((2.0, 0.9), RelationType.BEHIND),
        ((1.0, 0.0), None),  # the anchor itself
    ],
)
def test_view_sectors(s: tuple[float, float], expected: RelationType | None) -> None:
    anchor, eye = (1.0, 0.0), (0.0, 0.0)
    holding = [r for r in VIEW if view_relation(PY, r, s, anchor, eye, anchor)]
    assert holding == ([] if expected is None else [expected])


def test_view_from_an_explicit_viewpoint_and_a_degenerate_one() -> None:
    # looking along -y: +x is on the observer's left
    assert view_relation(PY, RelationType.LEFT_OF, (1.0, 0.0), (0.0, 0.0), (0.0, 5.0), (0.0, 0.0))
    for r in VIEW:  # eye on the target: no direction, no relation
        assert not view_relation(PY, r, (1.0, 0.0), (0.0, 0.0), (3.0, 3.0), (3.0, 3.0))


@pytest.mark.parametrize(
    ("s", "inside"),
    [((1.0, 0.0), True), ((1.0, 0.59), True), ((1.0, 0.61), False), ((2.0, 0.0), False),
     ((0.0, 0.0), False), ((-0.1, 0.0), False), ((1.9, -0.5), True)],
)  # fmt: skip
def test_between(s: tuple[float, float], inside: bool) -> None:
    assert between(PY, s, (0.0, 0.0), (2.0, 0.0), 0.3) is inside  # tolerance 0.3 * |ab| = 0.6


# -- the formulas give the same answers in every engine ------------------------------------

finite = st.floats(-1e6, 1e6, allow_nan=False, allow_infinity=False) | st.sampled_from(
    [0.0, -0.0, 1.0, 0.1, 0.2, 0.3, 1e-300, 5e-324]
)
xy = st.tuples(finite, finite)
_SQLITE = sa.create_engine("sqlite://")
_OX = ox.Store()
_RDFLIB = rdflib.Graph()


def _sqlite(expr: sa.ColumnElement[object]) -> object:
    with _SQLITE.connect() as conn:
        return conn.execute(sa.select(expr)).scalar_one()


def _sparql(expr: str) -> list[object]:
    text = f"SELECT ?x WHERE {{ BIND ({expr} AS ?x) }}"
    ox_value = next(iter(_OX.query(text)))[0]
    rd_value = next(iter(_RDFLIB.query(text)))[0]
    return [ox_value.value, rd_value.toPython()]


def _c(p: tuple[float, float]) -> tuple[str, str]:
    return (SPARQL.const(p[0]), SPARQL.const(p[1]))


def _q(p: tuple[float, float]) -> tuple[sa.ColumnElement[float], sa.ColumnElement[float]]:
    return (SQL.const(p[0]), SQL.const(p[1]))


@settings(max_examples=15, deadline=None)
@given(xy, xy, xy, xy, st.sampled_from(VIEW))
def test_view_relation_agrees_across_engines(
    s: tuple[float, float],
    a: tuple[float, float],
    eye: tuple[float, float],
    target: tuple[float, float],
    rel: RelationType,
) -> None:
    expected = view_relation(PY, rel, s, a, eye, target)
    assert bool(_sqlite(view_relation(SQL, rel, _q(s), _q(a), _q(eye), _q(target)))) is expected
    got = _sparql(view_relation(SPARQL, rel, _c(s), _c(a), _c(eye), _c(target)))
    assert got[0] in ("true", "false") and (got[0] == "true") is expected
    assert got[1] is expected


@settings(max_examples=15, deadline=None)
@given(xy, xy, xy)
def test_between_and_distance_agree_across_engines(
    s: tuple[float, float], a: tuple[float, float], b: tuple[float, float]
) -> None:
    expected = between(PY, s, a, b, 0.3)
    assert bool(_sqlite(between(SQL, _q(s), _q(a), _q(b), 0.3))) is expected
    got = _sparql(between(SPARQL, _c(s), _c(a), _c(b), 0.3))
    assert (got[0] == "true") is expected and got[1] is expected
    p3, q3 = (s[0], s[1], a[0]), (b[0], b[1], a[1])
    d = squared_distance(PY, p3, q3)
    sp, sq = _q3(p3), _q3(q3)
    assert _sqlite(squared_distance(SQL, sp, sq)) == d
    dp = (double(p3[0]), double(p3[1]), double(p3[2]))
    dq = (double(q3[0]), double(q3[1]), double(q3[2]))
    ox_d, rd_d = _sparql(squared_distance(SPARQL, dp, dq))
    assert float(str(ox_d)) == d and rd_d == d


def _q3(
    p: tuple[float, float, float],
) -> tuple[sa.ColumnElement[float], sa.ColumnElement[float], sa.ColumnElement[float]]:
    return (SQL.const(p[0]), SQL.const(p[1]), SQL.const(p[2]))


def _d3(v: tuple[float, ...]) -> tuple[str, str, str]:
    return (double(v[0]), double(v[1]), double(v[2]))


Point = tuple[float, float, float]


def _box(spans: list[tuple[float, float]]) -> tuple[Point, Point, Point]:
    """A box's low and high corners and its centre (the centre rounded as a store would)."""
    lo = (min(spans[0]), min(spans[1]), min(spans[2]))
    hi = (max(spans[0]), max(spans[1]), max(spans[2]))
    mid = ((lo[0] + hi[0]) * 0.5, (lo[1] + hi[1]) * 0.5, (lo[2] + hi[2]) * 0.5)
    return lo, hi, mid


def _exact_box_distance(p: Point, lo: Point, hi: Point) -> Fraction:
    """The squared distance from ``p`` to the nearest point of the box, in rationals."""
    gaps = [max(Fraction(a) - Fraction(c), Fraction(0), Fraction(c) - Fraction(b))
            for c, a, b in zip(p, lo, hi, strict=True)]  # fmt: skip
    return sum((g * g for g in gaps), Fraction(0))


def _engines_agree(metric: str, p: Point, mid: Point, lo: Point, hi: Point, got: float) -> None:
    """SQLite, Oxigraph and rdflib give the metric's value exactly as Python does."""
    sql = reference_distance(SQL, metric, _q3(p), _q3(mid), _q3(lo), _q3(hi))
    assert _sqlite(sql) == got
    sparql = reference_distance(SPARQL, metric, _d3(p), _d3(mid), _d3(lo), _d3(hi))
    ox_d, rd_d = _sparql(sparql)
    assert float(str(ox_d)) == got and rd_d == got


@settings(max_examples=40, deadline=None)
@given(
    st.tuples(finite, finite, finite), st.lists(st.tuples(finite, finite), min_size=3, max_size=3)
)
def test_box_distance_agrees_across_engines_and_with_exact_arithmetic(
    p: tuple[float, float, float], spans: list[tuple[float, float]]
) -> None:
    lo, hi, mid = _box(spans)
    got = reference_distance(PY, "box_distance", p, mid, lo, hi)
    exact = _exact_box_distance(p, lo, hi)
    # a subtraction, a square and two additions: a few ulps; squares of tiny gaps underflow
    assert abs(Fraction(got) - exact) <= Fraction(8, 2**53) * exact + Fraction(2.3e-308)
    _engines_agree("box_distance", p, mid, lo, hi, got)


@settings(max_examples=40, deadline=None)
@given(
    st.tuples(finite, finite, finite), st.lists(st.tuples(finite, finite), min_size=3, max_size=3)
)
def test_box_centroid_distance_agrees_across_engines_and_with_exact_arithmetic(
    p: tuple[float, float, float], spans: list[tuple[float, float]]
) -> None:
    lo, hi, mid = _box(spans)
    got = reference_distance(PY, "box_centroid_distance", p, mid, lo, hi)
    # exact: the squared box distance plus the weight times the squared centroid distance
    centre = sum((Fraction(c) - Fraction(m)) ** 2 for c, m in zip(p, mid, strict=True))
    box_part = _exact_box_distance(p, lo, hi)
    exact = box_part + Fraction(CENTROID_TIE_WEIGHT) * centre
    # the box part as box_distance's bound, the centroid part a few more roundings of its
    # own (the midpoint is a rounded input), the sum one more
    eps = Fraction(1, 2**52)
    bound = 8 * eps * box_part + 16 * eps * Fraction(CENTROID_TIE_WEIGHT) * centre + 2 * eps * exact
    assert abs(Fraction(got) - exact) <= bound + Fraction(2.3e-308)
    _engines_agree("box_centroid_distance", p, mid, lo, hi, got)


@settings(max_examples=60, deadline=None)
@given(
    st.tuples(finite, finite, finite),
    st.lists(st.tuples(finite, finite), min_size=3, max_size=3),
    st.sampled_from(["end_distance", "corner_distance"]),
)
def test_footprint_distances_agree_across_engines_and_with_exact_arithmetic(
    p: tuple[float, float, float], spans: list[tuple[float, float]], metric: str
) -> None:
    lo, hi, mid = _box(spans)
    got = reference_distance(PY, metric, p, mid, lo, hi)
    # exact, in rationals: per horizontal axis the offset from the nearer edge line and from
    # the middle line; the long axis is chosen as the doubles compare the two extents
    edge, middle = [], []
    for axis in (0, 1):
        a, b, c = Fraction(lo[axis]), Fraction(hi[axis]), Fraction(p[axis])
        off = abs(c - (a + b) / 2)
        edge.append(off - (b - a) / 2)
        middle.append(off)
    if metric == "corner_distance":
        parts = (edge[0], edge[1])
    elif hi[0] - lo[0] >= hi[1] - lo[1]:
        parts = (edge[0], middle[1])
    else:
        parts = (middle[0], edge[1])
    exact = parts[0] ** 2 + parts[1] ** 2
    # each offset is a few roundings of numbers up to m in size, and may cancel: its error
    # is bounded by the inputs' size, not its own (8 ulps of m, generously); squares of
    # tiny offsets underflow
    eps = Fraction(1, 2**52)
    m = max(Fraction(abs(v)) for v in (*p[:2], *lo[:2], *hi[:2]))
    delta = 8 * eps * m
    bound = sum(2 * abs(x) * delta + delta * delta for x in parts) + 8 * eps * exact
    assert abs(Fraction(got) - exact) <= bound + Fraction(2.3e-308)
    _engines_agree(metric, p, mid, lo, hi, got)


def test_segment_distance_by_hand() -> None:
    a, b = (0.0, 0.0), (4.0, 0.0)
    cases = {(1.0, 2.0): 4.0, (2.0, -0.5): 0.25, (-3.0, 4.0): 25.0, (6.0, 1.0): 5.0}
    assert {p: segment_distance(PY, p, a, b) for p in cases} == cases
    assert segment_distance(PY, (1.0, 2.0), b, a) == 4.0  # either way round
    assert segment_distance(PY, (3.0, 4.0), (1.0, 1.0), (1.0, 1.0)) == 13.0  # a point


def _exact_segment_distance(
    s: tuple[float, float], a: tuple[float, float], b: tuple[float, float]
) -> Fraction:
    u = [Fraction(q) - Fraction(p) for p, q in zip(a, b, strict=True)]
    w = [Fraction(q) - Fraction(p) for p, q in zip(a, s, strict=True)]
    l2 = u[0] * u[0] + u[1] * u[1]
    t = min(max((w[0] * u[0] + w[1] * u[1]) / l2, Fraction(0)), Fraction(1)) if l2 else 0
    return (w[0] - t * u[0]) ** 2 + (w[1] - t * u[1]) ** 2


@settings(max_examples=60, deadline=None)
@given(xy, xy, xy)
def test_segment_distance_agrees_across_engines_and_with_exact_arithmetic(
    s: tuple[float, float], a: tuple[float, float], b: tuple[float, float]
) -> None:
    got = segment_distance(PY, s, a, b)
    exact = _exact_segment_distance(s, a, b)
    # each offset from the nearest point is a few roundings of numbers up to m in size
    # (t's own rounding moves the point by at most a few ulps of |w|); where |b - a|^2
    # underflows (|b - a| < 1.5e-154) t is off by up to 1, which moves the point by at most
    # |b - a|; squares of tiny offsets underflow
    eps = Fraction(1, 2**52)
    m = max(Fraction(abs(v)) for v in (*s, *a, *b))
    delta = 32 * eps * m + Fraction(4e-154)
    offsets = exact**0.5  # a float bound is enough for the slack term
    bound = 2 * 2 * Fraction(offsets) * delta + 2 * delta * delta + 8 * eps * exact
    assert abs(Fraction(got) - exact) <= bound + Fraction(2.3e-308)
    assert _sqlite(segment_distance(SQL, _q(s), _q(a), _q(b))) == got
    ox_d, rd_d = _sparql(segment_distance(SPARQL, _c(s), _c(a), _c(b)))
    assert float(str(ox_d)) == got and rd_d == got


@settings(max_examples=100, deadline=None)
@given(st.text(st.characters(blacklist_categories=("Cs",), blacklist_characters="\x00")))
def test_sparql_literals_read_back_exactly(text: str) -> None:
    query = f"SELECT ?x WHERE {{ BIND ({literal(text)} AS ?x) }}"
    assert next(iter(_OX.query(query)))[0].value == text
    assert str(next(iter(_RDFLIB.query(query)))[0]) == text
