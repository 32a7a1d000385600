"""Each edge rule against numbers worked out by hand on a few boxes."""

from __future__ import annotations

import math

import pytest

from causalsplat.graph import EdgeConfig, build_relations
from graph_store import Relation
from tests.causalsplat.graph._boxes import box, cube, find, triples


def of_type(relations: tuple[Relation, ...], *kinds: str) -> set[tuple[int, str, int]]:
    return {t for t in triples(relations) if t[1] in kinds}


# -- above / below -------------------------------------------------------------------------


def test_vertical_rule_by_hand() -> None:
    # S_xy = |(4, 3)| = 5; b̄ = (1, 1): D = min(max(0.55·√2, 0.4), 1.75) = 0.55·√2.
    # B - A: h = 0.5 <= D, d = √4.25, |Δz|/d = 2/√4.25 = 0.970 > 0.3.
    scene = [cube(0, (0, 0, 0)), cube(1, (0.3, 0.4, 2.0)), cube(2, (4, 3, 0))]
    relations = build_relations(scene)
    assert triples(relations) == {
        (1, "above", 0),
        (0, "below", 1),
        (0, "near", 1),  # d = 2.062 < 1.5·(√2/2 + √2/2) = 2.121
        (1, "near", 0),
    }
    above = find(relations, 1, "above", 0)
    assert above == pytest.approx(
        {
            "distance": math.sqrt(4.25),
            "horizontal_distance": 0.5,
            "vertical_ratio": 2 / math.sqrt(4.25),
            "horizontal_tolerance": 0.55 * math.sqrt(2),
            "height_difference": 2.0,
        },
        rel=1e-12,
    )
    below = find(relations, 0, "below", 1)
    assert below == pytest.approx({**above, "height_difference": -2.0}, rel=1e-12)


def test_vertical_rule_fails_on_ratio_or_horizontal_distance() -> None:
    far = cube(2, (4, 3, 0))
    low = [cube(0, (0, 0, 0)), cube(1, (0.3, 0.4, 0.15)), far]  # 0.15/√0.2725 = 0.287 <= 0.3
    assert not of_type(build_relations(low), "above", "below")
    wide = [cube(0, (0, 0, 0)), cube(1, (0.6, 0.6, 2.0)), far]  # h = 0.849 > D = 0.778
    assert not of_type(build_relations(wide), "above", "below")


def test_horizontal_tolerance_is_clamped_below_by_the_scene() -> None:
    # b̄ = (0.1, 0.1): 0.55·0.1414 = 0.078 < 0.08·S_xy = 0.08·10 = 0.8, so D = 0.8.
    scene = [cube(0, (0, 0, 0), 0.1), cube(1, (0.3, 0, 1), 0.1), cube(2, (10, 0, 0), 0.1)]
    relations = build_relations(scene)
    assert of_type(relations, "above") == {(1, "above", 0)}
    evidence = find(relations, 1, "above", 0)
    assert evidence["horizontal_tolerance"] == pytest.approx(0.8, rel=1e-12)
    assert evidence["vertical_ratio"] == pytest.approx(1 / math.sqrt(1.09), rel=1e-12)


def test_horizontal_tolerance_is_clamped_above_by_the_scene() -> None:
    # b̄ = (4, 4): 0.55·√32 = 3.11 > 0.35·S_xy = 0.35·2 = 0.7, so D = 0.7.
    slab = box(0, (-2, -2, -0.05), (2, 2, 0.05))
    board = box(1, (-1.5, -2, 0.95), (2.5, 2, 1.05))
    scene = [slab, board, cube(2, (2, 0, 0), 0.1)]
    relations = build_relations(scene)
    assert of_type(relations, "above") == {(1, "above", 0)}
    assert find(relations, 1, "above", 0)["horizontal_tolerance"] == pytest.approx(0.7, rel=1e-12)
    moved = box(1, (-1.2, -2, 0.95), (2.8, 2, 1.05))  # h = 0.8 > 0.7
    assert not of_type(build_relations([slab, moved, scene[2]]), "above")


# -- supported_by / supports ---------------------------------------------------------------

FLOOR = box(0, (-1, -1, -0.1), (3, 2, 0), "floor")
TABLE = box(1, (0, 0, 0), (2, 1, 0.8), "table")
CUP = box(2, (0.5, 0.25, 0.78), (0.7, 0.45, 0.98), "cup")
BOOK = box(3, (1.8, 0.2, 0.8), (2.4, 0.6, 0.85), "book")  # 1/3 of it over the table
PLATE = box(4, (1.9, 0.65, 0.8), (2.5, 0.95, 0.82), "plate")  # 1/6 of it over the table


def test_support_rule_by_hand() -> None:
    # S_z = 0.98 - (-0.1) = 1.08, so the touch tolerance is 0.06·1.08 = 0.0648.
    relations = build_relations([FLOOR, TABLE, CUP, BOOK, PLATE])
    assert of_type(relations, "supported_by") == {
        (1, "supported_by", 0),
        (2, "supported_by", 1),
        (3, "supported_by", 1),
    }
    assert of_type(relations, "supports") == {
        (0, "supports", 1),
        (1, "supports", 2),
        (1, "supports", 3),
    }
    cup = find(relations, 2, "supported_by", 1)
    assert cup == pytest.approx(
        {
            "gap": 0.78 - 0.8,
            "overlap": 1.0,
            "touch_tolerance": 0.06 * 1.08,
            "distance": math.sqrt(0.4**2 + 0.15**2 + 0.48**2),
        },
        rel=1e-12,
    )
    assert find(relations, 1, "supports", 2) == cup
    assert find(relations, 3, "supported_by", 1)["overlap"] == pytest.approx(1 / 3, rel=1e-12)
    table = find(relations, 1, "supported_by", 0)
    assert table["gap"] == 0.0 and table["overlap"] == 1.0


def test_support_tolerance_and_overlap_thresholds() -> None:
    tight = EdgeConfig(touch_fraction=0.01)  # 0.0108 < |gap| = 0.02: the cup floats
    assert (2, "supported_by", 1) not in triples(build_relations([FLOOR, TABLE, CUP], tight))
    strict = EdgeConfig(support_overlap=0.34)  # the book's 1/3 is no longer enough
    assert (3, "supported_by", 1) not in triples(build_relations([FLOOR, TABLE, BOOK], strict))


def test_floor_supports_from_its_whole_slab_and_nothing_without_a_floor() -> None:
    thick = box(0, (-1, -1, -0.1), (3, 2, 0.3), "Floor ")  # a thick, noisy floor box
    assert (1, "supported_by", 0) in triples(build_relations([thick, TABLE, CUP]))
    without = triples(build_relations([TABLE, CUP]))
    assert {t for t in without if t[1] == "supported_by"} == {(2, "supported_by", 1)}


def test_walls_and_ceilings_support_nothing_and_are_never_supported() -> None:
    for category in ("wall", "ceiling"):
        lower = box(1, (0, 0, 0), (2, 1, 0.8), category)
        relations = build_relations([FLOOR, lower, CUP])
        assert of_type(relations, "supported_by", "supports") == set(), category


def test_an_entity_keeps_all_its_supporters() -> None:
    left, right = box(0, (0, 0, 0), (1, 1, 0.7)), box(1, (1.5, 0, 0), (2.5, 1, 0.7))
    plank = box(2, (0.5, 0.2, 0.7), (2.0, 0.8, 0.75))  # a third of it on each table
    relations = build_relations([left, right, plank])
    assert of_type(relations, "supported_by") == {(2, "supported_by", 0), (2, "supported_by", 1)}
    assert find(relations, 2, "supported_by", 0)["overlap"] == pytest.approx(1 / 3, rel=1e-12)


# -- inside / contains ---------------------------------------------------------------------


def test_containment_rule_by_hand() -> None:
    outer = box(0, (0, 0, 0), (1, 1, 1))
    inner = box(1, (0.1, 0.1, 0.1), (0.5, 0.5, 0.5))
    mostly = box(2, (0.73, 0.2, 0.2), (1.03, 0.5, 0.5))  # 0.27/0.3 = 0.9 of it inside
    partly = box(3, (0.8, 0.6, 0.6), (1.1, 0.95, 0.95))  # 0.2/0.3 = 0.67 of it inside
    relations = build_relations([outer, inner, mostly, partly])
    assert of_type(relations, "inside") == {(1, "inside", 0), (2, "inside", 0)}
    assert of_type(relations, "contains") == {(0, "contains", 1), (0, "contains", 2)}
    assert find(relations, 1, "inside", 0) == pytest.approx(
        {"overlap": 1.0, "volume_ratio": 0.064, "distance": math.sqrt(3 * 0.2**2)}, rel=1e-12
    )
    assert find(relations, 2, "inside", 0)["overlap"] == pytest.approx(0.9, rel=1e-12)
    assert find(relations, 2, "inside", 0)["volume_ratio"] == pytest.approx(0.027, rel=1e-12)


def test_no_containment_with_structure_or_between_equal_boxes() -> None:
    room = box(0, (-1, -1, -0.1), (2, 2, 2), "floor")
    twin_a, twin_b = cube(1, (0.5, 0.5, 0.5)), cube(2, (0.5, 0.5, 0.5))
    assert of_type(build_relations([room, twin_a, twin_b]), "inside", "contains") == set()


# -- near / next_to ------------------------------------------------------------------------


def test_proximity_rules_by_hand() -> None:
    # Every footprint is 0.6 x 0.8 (half-diagonal 0.5), so near means d < 1.5.
    a = box(0, (0, 0, 0), (0.6, 0.8, 1))
    b = box(1, (1.2, 0, 0.5), (1.8, 0.8, 1.5))  # d = √(1.2² + 0.5²) = 1.3
    c = box(2, (0, 0, 1.1), (0.6, 0.8, 1.3))  # right over a, z ranges apart
    relations = build_relations([a, b, c])
    near = {(0, 1), (1, 0), (0, 2), (2, 0), (1, 2), (2, 1)}
    assert of_type(relations, "near") == {(s, "near", d) for s, d in near}
    assert of_type(relations, "next_to") == {
        (s, "next_to", d) for s, d in ((0, 1), (1, 0), (1, 2), (2, 1))
    }
    assert find(relations, 0, "near", 1) == pytest.approx(
        {"distance": 1.3, "near_threshold": 1.5}, rel=1e-12
    )
    assert find(relations, 1, "next_to", 0) == pytest.approx(
        {"distance": 1.3, "near_threshold": 1.5, "vertical_overlap": 0.5}, rel=1e-12
    )
    assert find(relations, 2, "next_to", 1)["vertical_overlap"] == pytest.approx(0.2, rel=1e-12)


def test_structure_takes_part_in_proximity_only_when_asked() -> None:
    wall = box(0, (0, 0, 0), (4, 0.1, 2.5), "wall")
    chair = box(1, (1, 0.2, 0), (1.5, 0.7, 0.9))
    assert triples(build_relations([wall, chair])) == set()
    with_structure = triples(build_relations([wall, chair], EdgeConfig(relate_structural=True)))
    assert {(0, "near", 1), (1, "near", 0), (0, "next_to", 1)} <= with_structure
