"""An object's own front: "in front of the toilet", "looking at the front of the toilet,
the towel on the left".

Object tables with annotated fronts (the objects input's ``facing``) say which way a toilet
faces; without one the reasoner looks from the middle of the room. Rooms are objects
documents written for these tests; the answers are worked out by hand below.
"""

from __future__ import annotations

from typing import Any

import pytest

from causalsplat.reason.offline import OfflineReasoner
from tests.causalsplat.reason.rooms import Box
from tests.causalsplat.reason.rooms import room_of_boxes as _room

REASONER = OfflineReasoner(embeddings=False)


def room(facing: list[float] | None) -> list[Box]:
    """A 6 x 4 m room (centre (3, 2)); the toilet in its south-east corner faces north
    (``facing``) or has no stored front (``None``).

    Seen from the middle of the room the observer looks south-east: chair 11 (west of the
    toilet) is in front of it, chair 10 (north of it) to its left; towel 20 (west) in
    front, towel 21 (east) behind. Standing in front of the toilet (north of it, looking
    south): chair 10 is in front, chair 11 to the right; towel 21 (east) to the left.
    """
    extra: dict[str, Any] = {} if facing is None else {"facing": facing}
    return [
        (0, "floor", (3.0, 2.0, -0.05), (6.0, 4.0, 0.1)),
        (1, "toilet", (5.5, 0.5, 0.4), (0.5, 0.7, 0.8), extra),
        (10, "chair", (5.5, 1.6, 0.45), (0.45, 0.45, 0.9)),
        (11, "chair", (4.3, 0.8, 0.45), (0.45, 0.45, 0.9)),
        (20, "towel", (5.1, 0.5, 1.0), (0.1, 0.3, 0.5)),
        (21, "towel", (5.95, 0.3, 1.0), (0.1, 0.3, 0.5)),
    ]


@pytest.mark.parametrize(
    ("text", "with_front", "without"),
    [
        ("the chair in front of the toilet", 10, 11),
        ("pick the chair that is in front of the toilet", 10, 11),
        ("looking at the front of the toilet, the towel on the left of it", 21, 20),
        ("facing the toilet, select the towel that is to the left of the toilet", 21, 20),
        # across from it: ahead of its front (north), or else towards the room's middle
        ("the chair across from the toilet", 10, 11),
        ("the chair opposite the toilet", 10, 11),
    ],
)
def test_relations_to_an_object_with_a_front_are_seen_from_its_front(
    text: str, with_front: int, without: int
) -> None:
    answer = REASONER.answer(text, _room(room([0.0, 2.0, 0.0])))
    assert answer.entity_ids == (with_front,)
    assert "seen from the front of 'toilet'" in answer.explanation
    plain = REASONER.answer(text, _room(room(None)))
    assert plain.entity_ids == (without,)
    assert "seen from the front" not in plain.explanation


def test_standing_at_an_object_is_not_standing_in_front_of_it() -> None:
    # "standing at the toilet": the observer is at the toilet, looking at the middle of the
    # room (north-west), whatever way the toilet faces: chair 10 (north) is on the right;
    # standing in front of it looking south, chair 11 (west) would be
    text = "standing at the toilet, the chair on the right"
    for facing in ([0.0, 1.0, 0.0], None):
        assert REASONER.answer(text, _room(room(facing))).entity_ids == (10,)
