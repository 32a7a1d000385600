"""Of several things between X and Y, the one most squarely between them.

A trash can beside the door and one halfway along the way from the desk to the door both lie
between them (``relate_between``); the one meant is the one on the line, not the one
nearest either end (the query language's ``segment_distance``). Rooms are objects
documents written for these tests.
"""

from __future__ import annotations

import pytest

from causalsplat.reason.offline import OfflineReasoner
from queries import Metric, Op
from tests.causalsplat.reason.rooms import Box
from tests.causalsplat.reason.rooms import room_of_boxes as _room

REASONER = OfflineReasoner(embeddings=False)

FLOOR: Box = (0, "floor", (3.0, 2.0, -0.05), (9.0, 7.0, 0.1))
CAN = (0.3, 0.3, 0.4)
#: a desk at the west end, a door 4 m east; trash can 10 stands 0.5 m off the way, beside
#: the door (0.64 m from it), trash can 11 on the way, 0.3 m off it (2.02 m from the desk)
ROOM: list[Box] = [
    FLOOR,
    (1, "desk", (0.0, 0.0, 0.4), (1.2, 0.6, 0.8)),
    (2, "door", (4.0, -0.1, 1.0), (0.9, 0.1, 2.0)),
    (10, "trash can", (3.6, 0.5, 0.2), CAN),
    (11, "trash can", (2.0, 0.3, 0.2), CAN),
    (3, "bed", (2.0, 4.0, 0.3), (2.0, 1.6, 0.6)),
]


@pytest.mark.parametrize(
    "text",
    [
        "the trash can between the desk and the door",
        "the trash can that is between the door and the desk",
        "pick the trash can in between the desk and the door",
    ],
)
def test_of_several_between_the_one_on_the_line_between_them(text: str) -> None:
    answer = REASONER.answer(text, _room(ROOM))
    assert answer.entity_ids == (11,)
    ranked = [s for s in answer.program.steps if s.metric is Metric.SEGMENT_DISTANCE]
    assert ranked and all(len(s.inputs) == 3 for s in ranked)
    assert "took the one nearest the line between them" in answer.explanation


def test_one_between_needs_no_tie_break() -> None:
    room = [b for b in ROOM if b[0] != 10]
    answer = REASONER.answer("the trash can between the desk and the door", _room(room))
    assert answer.entity_ids == (11,)
    assert any(s.op is Op.RELATE_BETWEEN for s in answer.program.steps)


def test_between_the_two_doors_measures_to_the_line_joining_them() -> None:
    # a second door 4 m north of the first: trash can 12 stands on the line between the
    # doors, 11 nearer the first door but off that line (it is on the desk-door line)
    room = [*ROOM, (4, "door", (4.0, 4.0, 1.0), (0.9, 0.1, 2.0)), (12, "trash can",
            (4.2, 2.5, 0.2), CAN)]  # fmt: skip
    answer = REASONER.answer("the trash can between the two doors", _room(room))
    assert answer.entity_ids == (12,)
