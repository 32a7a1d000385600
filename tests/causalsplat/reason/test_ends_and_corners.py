"""'At the end of the table', 'at the head of the table', 'at the corner of the desk'.

The chair at the end of a long table is the one by the middle of a short edge, farther
from the table's centroid than the chairs along its sides; the one at a corner sits by a
corner of its footprint (the query language's ``end_distance`` / ``corner_distance``).
Rooms are objects documents written for these tests.
"""

from __future__ import annotations

from typing import Any

import pytest

from causalsplat.reason.offline import OfflineReasoner
from queries import Metric
from tests.causalsplat.reason.rooms import Box
from tests.causalsplat.reason.rooms import room_of_boxes as _room

REASONER = OfflineReasoner(embeddings=False)

FLOOR: Box = (0, "floor", (0.0, 0.0, -0.05), (8.0, 8.0, 0.1))
CHAIR = (0.45, 0.45, 0.9)
#: a dining table 2.4 m long along y, 1 m wide; one chair at its north end, one by its
#: south-east corner, two along its west side (the nearest to its centroid among them)
TABLE_ROOM: list[Box] = [
    FLOOR,
    (1, "table", (0.0, 0.0, 0.4), (1.0, 2.4, 0.8)),
    (2, "chair", (0.0, 1.6, 0.45), CHAIR),
    (3, "chair", (0.8, -1.05, 0.45), CHAIR),
    (4, "chair", (-0.85, 0.3, 0.45), CHAIR),
    (5, "chair", (-0.85, -0.5, 0.45), CHAIR),
    (6, "sofa", (3.0, 3.0, 0.4), (2.0, 0.9, 0.8)),
]


def _metrics(answer: Any) -> set[Metric]:
    return {s.metric for s in answer.program.steps if s.metric is not None}


@pytest.mark.parametrize(
    "text",
    [
        "the chair at the end of the table",
        "chair on the end of the table",
        "the chair pushed in at the head of the table",
        "the brown chair is at the far end of the table",
    ],
)
def test_at_the_end_of_the_table_is_the_chair_by_a_short_edge(text: str) -> None:
    answer = REASONER.answer(text, _room(TABLE_ROOM))
    assert answer.entity_ids == (2,), answer.explanation
    assert Metric.END_DISTANCE in _metrics(answer)


@pytest.mark.parametrize(
    "text",
    [
        "the chair at the corner of the table",
        "the chair in the corner of the table",
        "a chair sits at the back left corner of the table",
    ],
)
def test_at_the_corner_of_the_table_is_the_chair_by_a_corner(text: str) -> None:
    answer = REASONER.answer(text, _room(TABLE_ROOM))
    assert answer.entity_ids == (3,), answer.explanation
    assert Metric.CORNER_DISTANCE in _metrics(answer)


def test_closest_to_the_table_measures_to_its_box_not_its_ends_or_corners() -> None:
    # the corner chair is 0.30 m off the table's east edge, the west chairs 0.35 m off
    # its west edge (their centroids are nearer the table's)
    answer = REASONER.answer("the chair closest to the table", _room(TABLE_ROOM))
    assert answer.entity_ids == (3,), answer.explanation
    assert _metrics(answer) == {Metric.BOX_CENTROID_DISTANCE}


def test_the_end_of_the_room_is_no_object_s_end() -> None:
    # "the end of the room" names a place in the room, not the end of an object
    answer = REASONER.answer("the sofa at the end of the room", _room(TABLE_ROOM))
    assert answer.entity_ids == (6,), answer.explanation
    assert Metric.END_DISTANCE not in _metrics(answer)


def test_with_more_said_the_end_breaks_the_tie() -> None:
    # "at the end of the table" keeps the chairs near it; what is left to choose among is
    # chosen by the end, not by the centroid
    answer = REASONER.answer(
        "this is a wooden chair. it is at the end of the table and close to the kitchen counter.",
        _room(TABLE_ROOM),
    )
    assert answer.entity_ids == (2,), answer.explanation
