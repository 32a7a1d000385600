"""Stiff and extreme scenes (DESIGN §12): finite evidence or a typed error, never NaN."""

from __future__ import annotations

import math

import pytest

from causalsplat.bench._edges_scenes import random_rooms
from causalsplat.errors import CausalSplatError
from causalsplat.graph import (
    EdgeConfig,
    EdgeConfigError,
    EdgeInputError,
    build_relations,
    build_relations_bruteforce,
)
from graph_store import Entity, Relation
from tests.causalsplat.graph._boxes import box, cube, find, triples


def all_finite(relations: tuple[Relation, ...]) -> bool:
    return all(math.isfinite(v) for r in relations for _, v in r.evidence)


def transformed(entities: tuple[Entity, ...], scale: float, offset: float) -> tuple[Entity, ...]:
    def move(p: tuple[float, float, float]) -> tuple[float, ...]:
        return tuple(v * scale + offset for v in p)

    return tuple(
        Entity(e.id, e.category, move(e.centroid), move(e.bbox_min), move(e.bbox_max))
        for e in entities
    )


SCENE = random_rooms(300, seed=3)
LENGTHS = {"distance", "horizontal_distance", "horizontal_tolerance", "height_difference",
           "gap", "touch_tolerance", "near_threshold", "vertical_overlap"}  # fmt: skip


@pytest.mark.parametrize("scale", [1e-3, 1e3, 1e-6, 1e4])
def test_units_do_not_change_relations(scale: float) -> None:
    base = build_relations(SCENE)
    scaled = build_relations(transformed(SCENE, scale, 0.0))
    assert triples(scaled) == triples(base)
    for a, b in zip(base, scaled, strict=True):
        for (name, va), (_, vb) in zip(a.evidence, b.evidence, strict=True):
            expected = va * scale if name in LENGTHS else va
            assert vb == pytest.approx(expected, rel=1e-9, abs=1e-12 * scale)


def test_an_offset_of_1e6_does_not_change_relations() -> None:
    base = build_relations(SCENE)
    scene = transformed(SCENE, 1.0, 1e6)
    moved = build_relations(scene)
    assert moved == build_relations_bruteforce(scene)
    assert triples(moved) == triples(base)
    for a, b in zip(base, moved, strict=True):
        assert b.evidence_dict == pytest.approx(a.evidence_dict, rel=1e-6, abs=1e-6)


@pytest.mark.parametrize("up", ["x", "y"])
def test_another_up_axis_gives_the_same_relations(up: str) -> None:
    def turn(p: tuple[float, float, float]) -> tuple[float, float, float]:
        x, y, z = p
        return (z, x, y) if up == "x" else (y, z, x)

    turned = tuple(
        Entity(e.id, e.category, turn(e.centroid), turn(e.bbox_min), turn(e.bbox_max))
        for e in SCENE[:120]
    )
    assert build_relations(turned, up_axis=up) == build_relations(SCENE[:120])


def test_no_entity_and_one_entity_give_no_relations() -> None:
    assert build_relations([]) == () == build_relations_bruteforce([])
    assert build_relations([cube(0, (0, 0, 0))]) == ()
    assert build_relations([box(0, (1, 1, 1), (1, 1, 1))]) == ()


def test_coincident_centroids() -> None:
    big, small = cube(0, (0, 0, 0)), cube(1, (0, 0, 0), 0.5)
    relations = build_relations([big, small])
    assert triples(relations) == {
        (0, "near", 1), (1, "near", 0), (0, "next_to", 1), (1, "next_to", 0),
        (1, "inside", 0), (0, "contains", 1),
    }  # fmt: skip
    assert find(relations, 0, "near", 1)["distance"] == 0.0
    assert all_finite(relations)


def test_coplanar_centroids_are_never_above_each_other() -> None:
    flat = [cube(k, (k % 7 * 0.3, k // 7 * 0.3, 0.0), 0.4) for k in range(49)]
    relations = build_relations(flat)
    assert not {t for t in triples(relations) if t[1] in ("above", "below")}
    assert relations == build_relations_bruteforce(flat) and all_finite(relations)


def test_centroids_on_one_vertical_line_still_stack() -> None:
    # S_xy = 0, so D = 0; h = 0 <= D keeps the paper's rule meaningful for a column.
    column = [cube(k, (0, 0, k)) for k in range(3)]
    relations = build_relations(column)
    assert {t for t in triples(relations) if t[1] == "above"} == {
        (1, "above", 0), (2, "above", 1), (2, "above", 0)
    }  # fmt: skip
    assert {t for t in triples(relations) if t[1] == "supported_by"} == {
        (1, "supported_by", 0), (2, "supported_by", 1)
    }  # fmt: skip
    assert find(relations, 2, "above", 0)["horizontal_tolerance"] == 0.0
    assert relations == build_relations_bruteforce(column)


def test_zero_size_boxes() -> None:
    table = box(0, (-1, -1, -1), (1, 1, 0))
    on_top = box(1, (0.5, 0.5, 0), (0.5, 0.5, 0))  # a point on the table top
    within = box(2, (0.2, 0.2, -0.5), (0.2, 0.2, -0.5))  # a point inside it
    flat = box(3, (-0.5, 0.8, 0), (0.5, 0.8, 0.3))  # a vertical sheet on the table
    scene = [table, on_top, within, flat, box(4, (0, 0, 3), (0, 0, 3))]
    relations = build_relations(scene)
    assert {(1, "supported_by", 0), (3, "supported_by", 0), (2, "inside", 0)} <= triples(relations)
    assert find(relations, 1, "supported_by", 0)["overlap"] == 1.0
    inside = find(relations, 2, "inside", 0)
    assert inside == {"overlap": 1.0, "volume_ratio": 0.0, "distance": pytest.approx(0.08**0.5)}
    assert all_finite(relations) and relations == build_relations_bruteforce(scene)


def test_huge_and_tiny_but_finite_scenes_give_finite_evidence() -> None:
    for scale, offset in ((1e-150, 0.0), (1e90, 0.0), (1.0, 5e99)):
        scene = transformed(SCENE[:80], scale, offset)
        relations = build_relations(scene)
        assert all_finite(relations)
        assert relations == build_relations_bruteforce(scene)


def test_coordinates_beyond_1e100_are_refused() -> None:
    with pytest.raises(EdgeInputError, match=r"entity 1 .* magnitude 2e\+101"):
        build_relations([cube(0, (0, 0, 0)), cube(1, (2e101, 0, 0))])


def test_bad_input_raises_typed_errors() -> None:
    with pytest.raises(EdgeInputError, match=r"entities\[1\] is a str"):
        build_relations([cube(0, (0, 0, 0)), "cup"])  # type: ignore[list-item]
    with pytest.raises(EdgeInputError, match="duplicate entity id 4"):
        build_relations([cube(4, (0, 0, 0)), cube(4, (1, 0, 0))])
    with pytest.raises(EdgeInputError, match="up axis"):
        build_relations([], up_axis="w")
    with pytest.raises(EdgeInputError, match="candidates"):
        build_relations([], candidates="octree")  # type: ignore[arg-type]
    assert issubclass(EdgeInputError, CausalSplatError)


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"tau_v": 1.0}, "tau_v"),
        ({"tau_v": -0.1}, "tau_v"),
        ({"tau_v": math.nan}, "tau_v"),
        ({"near_factor": math.inf}, "near_factor"),
        ({"support_overlap": 0.0}, "support_overlap"),
        ({"contain_overlap": 1.5}, "contain_overlap"),
        ({"horizontal_min_fraction": 0.5}, "horizontal_max_fraction"),
        ({"touch_fraction": "0.1"}, "touch_fraction"),
        ({"floor_categories": "floor"}, "floor_categories"),
        ({"wall_categories": ("wall", "")}, "wall_categories"),
        ({"ceiling_categories": ("Floor",)}, "'floor' is in two"),
        ({"relate_structural": 1}, "relate_structural"),
    ],
)
def test_config_values_out_of_range(changes: dict[str, object], message: str) -> None:
    with pytest.raises(EdgeConfigError, match=message):
        EdgeConfig(**changes)  # type: ignore[arg-type]


def test_config_normalises_categories_and_exports_plain_values() -> None:
    config = EdgeConfig(floor_categories=["Floor ", "rug"])  # type: ignore[arg-type]
    assert config.floor_categories == ("floor", "rug")
    exported = config.to_dict()
    assert exported["floor_categories"] == ["floor", "rug"]
    assert exported["touch_height_factor"] == "inf" and exported["tau_v"] == 0.3
