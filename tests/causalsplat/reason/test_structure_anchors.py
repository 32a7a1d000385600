"""Distances to walls, floors and ceilings are distances to their surfaces.

A wall's centroid is the middle of the wall, metres from the chair pushed against its end;
"against the wall" and "closest to the floor" measure to the structure's bounding box
(the query language's ``box_distance``), other anchors to their centroids as before. Rooms
are objects documents written for these tests.
"""

from __future__ import annotations

from typing import Any

from causalsplat.reason._builder import SCENE, ProgramBuilder
from causalsplat.reason.offline import OfflineReasoner
from queries import Metric, Op
from tests.causalsplat.reason.rooms import Box
from tests.causalsplat.reason.rooms import room_of_boxes as _room

REASONER = OfflineReasoner(embeddings=False)

FLOOR: Box = (0, "floor", (0.0, 0.0, -0.05), (8.0, 8.0, 0.1))
NORTH_WALL: Box = (1, "wall", (0.0, 3.95, 1.25), (8.0, 0.1, 2.5))
CHAIR = (0.5, 0.5, 0.9)


def _metrics(answer: Any) -> set[Metric]:
    return {s.metric for s in answer.program.steps if s.metric is not None}


def test_against_the_wall_is_the_chair_at_the_wall_not_the_one_nearest_its_middle() -> None:
    # chair 2 stands against the wall's east end (0.2 m from it, 3.5 m from its centroid);
    # chair 3 in the room, 1.7 m out from the wall's middle (nearer its centroid)
    ctx = _room([FLOOR, NORTH_WALL, (2, "chair", (3.5, 3.65, 0.45), CHAIR),
                 (3, "chair", (0.0, 2.0, 0.45), CHAIR)])  # fmt: skip
    answer = REASONER.answer("the chair against the wall", ctx)
    assert answer.entity_ids == (2,), answer.explanation
    assert Metric.BOX_DISTANCE in _metrics(answer)
    farthest = REASONER.answer("the chair farthest from the wall", ctx)
    assert farthest.entity_ids == (3,), farthest.explanation


def test_closest_to_the_floor_is_the_lowest_not_the_one_over_the_floor_s_middle() -> None:
    # the floor's centroid is under the middle of the room: the lamp hung over it is nearer
    # that point than the lamp standing low in a corner
    ctx = _room([FLOOR, (2, "lamp", (3.5, -3.5, 0.5), (0.3, 0.3, 1.0)),
                 (3, "lamp", (0.2, 0.2, 1.6), (0.3, 0.3, 0.3))])  # fmt: skip
    answer = REASONER.answer("the lamp closest to the floor", ctx)
    assert answer.entity_ids == (2,), answer.explanation


def test_closest_to_an_object_is_nearest_its_box_and_farthest_from_its_centroid() -> None:
    # a long table: the chair at its end is nearer its surface (0.40 m off its end), the
    # chair at its side nearer its centroid (0.55 m off its side): "closest to" measures to
    # the box, as Sr3D's nearest points do; "farthest from" and tie-breaks to the centroid
    ctx = _room([FLOOR, (1, "table", (0.0, 0.0, 0.4), (3.0, 0.9, 0.8)),
                 (2, "chair", (1.9, 0.0, 0.45), CHAIR),
                 (3, "chair", (0.0, 1.0, 0.45), CHAIR)])  # fmt: skip
    answer = REASONER.answer("the chair closest to the table", ctx)
    assert answer.entity_ids == (2,), answer.explanation
    assert _metrics(answer) == {Metric.BOX_CENTROID_DISTANCE}
    farthest = REASONER.answer("the chair farthest from the table", ctx)
    assert farthest.entity_ids == (2,), farthest.explanation
    assert _metrics(farthest) == {Metric.DISTANCE}


def test_the_metric_follows_the_categories_the_anchor_can_hold() -> None:
    ctx = _room([FLOOR, NORTH_WALL, (2, "chair", (3.5, 3.65, 0.45), CHAIR),
                 (3, "table", (0.0, 0.0, 0.4), (1.0, 1.0, 0.8))])  # fmt: skip
    b = ProgramBuilder(ctx)
    wall = b.add(Op.FILTER_CATEGORY, SCENE, value="wall")
    floor = b.add(Op.FILTER_CATEGORY, SCENE, value="floor")
    table = b.add(Op.FILTER_CATEGORY, SCENE, value="table")
    structure = b.union([wall, floor])
    assert b.categories(structure) == {"wall", "floor"}
    assert b.distance_to(structure) is Metric.BOX_DISTANCE
    # a subset of the walls is still walls; a union with a table is not only structure
    nearest_wall = b.add(Op.ARGMIN, wall, table, metric=Metric.DISTANCE)
    assert b.distance_to(nearest_wall) is Metric.BOX_DISTANCE
    assert b.distance_to(b.union([wall, table])) is Metric.DISTANCE
    # the whole scene, or a text match, can hold anything
    assert b.categories(SCENE) is None
    assert b.distance_to(SCENE) is Metric.DISTANCE
    assert b.distance_to(b.add(Op.MATCH_TEXT, SCENE, value="wall", k=1)) is Metric.DISTANCE
