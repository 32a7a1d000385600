"""Left and right as the observer sees them, observers who look *from* a place, and
relations that leave the choosing to what comes after them.

Rooms are objects documents (the ReferIt3D setting: labelled boxes, our edges), written
for these tests.
"""

from __future__ import annotations

from causalsplat.reason import SceneContext
from causalsplat.reason.offline import OfflineReasoner
from queries import Metric
from tests.causalsplat.reason.rooms import room_of_boxes as _room

REASONER = OfflineReasoner(embeddings=False)


FLOOR = (0, "floor", (0.0, 0.0, -0.05), (8.0, 8.0, 0.1))
BOX = (0.5, 0.5, 0.9)


def test_left_is_what_the_observer_sees_on_the_left_not_along_the_nearest_axis() -> None:
    # from the centre (0, 0) facing the window in the north-east corner: chair 2, north of
    # the line of sight, is on the left; chair 3, due east, on the right. Along the axis
    # nearest the observer's right (x), chair 3 would be the leftmost (smaller x).
    ctx = _room([FLOOR, (1, "window", (3.0, 3.0, 1.5), (1.0, 0.1, 1.0)),
                 (2, "chair", (2.0, 3.5, 0.45), BOX),
                 (3, "chair", (1.0, 0.0, 0.45), BOX)])  # fmt: skip
    left = REASONER.answer("facing the window, the chair on the left", ctx)
    right = REASONER.answer("facing the window, the chair on the right", ctx)
    assert (left.entity_ids, right.entity_ids) == ((2,), (3,))
    metrics = {s.metric for s in left.program.steps}
    assert Metric.RIGHTWARD in metrics, left.explanation


def test_looking_from_a_place_stands_there() -> None:
    # a toilet on the east wall, towels north and south of the room's middle: looking from
    # the toilet (westwards) the northern towel is on the right; looking *at* the toilet
    # from the middle, it is on the left
    ctx = _room([FLOOR, (1, "toilet", (3.5, 0.0, 0.4), (0.6, 0.8, 0.8)),
                 (2, "towel", (0.0, 2.0, 1.0), (0.4, 0.1, 0.6)),
                 (3, "towel", (0.0, -2.0, 1.0), (0.4, 0.1, 0.6))])  # fmt: skip
    assert REASONER.answer("looking from the toilet, the towel on the right", ctx).entity_ids == (
        2,
    )
    assert REASONER.answer("looking at the toilet, the towel on the right", ctx).entity_ids == (3,)


def test_looking_from_the_foot_of_a_bed_faces_it() -> None:
    # a bed against the north wall, a pillow at each side of its head: from its foot one
    # faces the bed (north), so the western pillow is on the left; looking from the bed
    # itself one faces the room (south), and the eastern pillow is on the left
    ctx = _room([FLOOR, (1, "bed", (0.0, 2.9, 0.3), (1.6, 2.0, 0.6)),
                 (2, "pillow", (-0.5, 3.6, 0.7), (0.5, 0.3, 0.2)),
                 (3, "pillow", (0.5, 3.6, 0.7), (0.5, 0.3, 0.2)),
                 (4, "desk", (0.0, -3.5, 0.4), (1.2, 0.6, 0.8))])  # fmt: skip
    for text in (
        "viewing from the foot of the bed, it's the pillow on the left",
        "looking from the foot of the bed, the pillow on the left",
    ):
        answer = REASONER.answer(text, ctx)
        assert answer.entity_ids == (2,), (text, answer.explanation)
    answer = REASONER.answer("looking from the bed, the pillow on the left", ctx)
    assert answer.entity_ids == (3,), answer.explanation


def test_a_relation_with_more_to_come_selects_and_the_last_one_chooses() -> None:
    # two dressers beside the bed (nothing is stored as under it) and a desk by the
    # lower one: "under the bed" keeps both, "farther from the desk" chooses
    ctx = _room([FLOOR, (1, "bed", (0.0, 0.0, 0.3), (2.0, 2.0, 0.6)),
                 (2, "dresser", (-1.4, 0.0, 0.35), (0.6, 0.5, 0.7)),
                 (3, "dresser", (1.4, 0.0, 0.45), (0.6, 0.5, 0.9)),
                 (4, "desk", (-3.0, 0.0, 0.4), (1.2, 0.6, 0.8))])  # fmt: skip
    answer = REASONER.answer("the dresser under the bed, farther from the desk", ctx)
    assert answer.entity_ids == (3,), answer.explanation
    # alone, the relaxed relation still picks one: the lowest of what is near the bed
    assert REASONER.answer("the dresser under the bed", ctx).entity_ids == (2,)


def _row_of_tables() -> SceneContext:
    # three tables in a row west to east, larger eastwards; a window in the north-east corner
    return _room([FLOOR, (1, "table", (-2.0, 2.0, 0.4), (0.4, 0.4, 0.8)),
                  (2, "table", (0.0, 2.0, 0.4), (0.6, 0.6, 0.8)),
                  (3, "table", (2.0, 2.0, 0.4), (0.8, 0.8, 0.8)),
                  (4, "window", (3.8, 3.8, 1.5), (0.1, 1.0, 1.0))])  # fmt: skip


def test_what_singles_out_the_one_singles_out_the_target() -> None:
    ctx = _row_of_tables()
    # seen from the centre, looking north at the tables: west is on the left
    answer = REASONER.answer("the table is the furthest left one of the three tables", ctx)
    assert answer.entity_ids == (1,), answer.explanation


def test_an_ordinal_ranks_the_closest() -> None:
    ctx = _row_of_tables()
    assert REASONER.answer("the table closest to the window", ctx).entity_ids == (3,)
    assert REASONER.answer("the second closest table to the window", ctx).entity_ids == (2,)
    assert REASONER.answer("the table is the third closest to the window", ctx).entity_ids == (1,)


def test_the_target_is_what_a_later_clause_picks() -> None:
    ctx = _room([FLOOR, (1, "bed", (0.0, 0.0, 0.3), (2.0, 2.0, 0.6)),
                 (2, "pillow", (0.0, 0.8, 0.65), (0.5, 0.3, 0.15)),
                 (3, "pillow", (0.0, -2.5, 0.1), (0.5, 0.3, 0.15)),
                 (4, "lamp", (1.4, 0.9, 0.5), (0.3, 0.3, 1.0))])  # fmt: skip
    for text in (
        "look for the bed. choose the pillow on the bed",
        "find the bed, then you want the pillow on it",
        "next to the lamp is a bed, and you are looking for the pillow on top of it",
    ):
        answer = REASONER.answer(text, ctx)
        assert answer.entity_ids == (2,), (text, answer.explanation)
    # the first phrase picked already: nothing changes
    assert REASONER.answer("choose the pillow on the bed", ctx).entity_ids == (2,)


def test_a_leftmost_one_after_and_is_the_target_not_a_second_thing() -> None:
    ctx = _row_of_tables()
    answer = REASONER.answer("there are three tables, and you want the left-most one", ctx)
    assert answer.entity_ids == (1,), answer.explanation


def test_across_from_is_on_the_far_side_not_the_closest() -> None:
    # a door on the west wall; one whiteboard on the east wall facing it, one on the north
    # wall a metre from the door: the whiteboard across from the door is the far one
    ctx = _room([FLOOR, (1, "door", (-3.9, 0.0, 1.0), (0.1, 0.9, 2.0)),
                 (2, "whiteboard", (3.9, 0.3, 1.5), (0.05, 1.5, 1.0)),
                 (3, "whiteboard", (-2.5, 3.9, 1.5), (1.5, 0.05, 1.0))])  # fmt: skip
    for text in ("the whiteboard across from the door", "the whiteboard opposite the door",
                 "find the whiteboard that is directly opposite to the door"):  # fmt: skip
        answer = REASONER.answer(text, ctx)
        assert answer.entity_ids == (2,), (text, answer.explanation)
    assert Metric.FORWARD in {s.metric for s in answer.program.steps}
    # closest is still closest
    assert REASONER.answer("the whiteboard closest to the door", ctx).entity_ids == (3,)


def test_across_from_something_in_the_middle_is_the_closest() -> None:
    # a table in the middle of the room faces no way: across from it is read as closest
    ctx = _room([FLOOR, (1, "table", (0.05, 0.0, 0.4), (1.2, 0.8, 0.8)),
                 (2, "chair", (0.05, 1.0, 0.45), BOX),
                 (3, "chair", (3.0, -3.0, 0.45), BOX)])  # fmt: skip
    answer = REASONER.answer("the chair across from the table", ctx)
    assert answer.entity_ids == (2,)
    assert Metric.FORWARD not in {s.metric for s in answer.program.steps}, answer.explanation


def test_the_furthest_right_of_a_counted_group_is_its_rightmost_member() -> None:
    # three bottles along a shelf under the window (north), a cup further east: facing
    # the window, "the furthest right of the three bottles" is the eastmost bottle, not
    # the cup right of them, and "three" names no anchor
    ctx = _room([FLOOR, (1, "window", (0.0, 3.9, 1.5), (2.0, 0.1, 1.0)),
                 (2, "bottle", (-0.6, 3.0, 1.0), (0.1, 0.1, 0.3)),
                 (3, "bottle", (0.0, 3.0, 1.0), (0.1, 0.1, 0.3)),
                 (4, "bottle", (0.6, 3.0, 1.0), (0.1, 0.1, 0.3)),
                 (5, "cup", (1.4, 3.0, 1.0), (0.1, 0.1, 0.1))])  # fmt: skip
    for text in (
        "facing the window, it is the furthest right of the three bottles",
        "facing the window, it is the one farthest to the right of the bottles",
    ):
        answer = REASONER.answer(text, ctx)
        assert answer.entity_ids == (4,), answer.explanation
        assert "three" not in answer.explanation
    # "to the far right of" stays a relation
    answer = REASONER.answer("facing the window, the cup to the far right of the bottles", ctx)
    assert answer.entity_ids == (5,)
    assert "right_of 'bottle'" in answer.explanation


def test_a_place_after_a_restated_target_is_no_question_about_it() -> None:
    # "the item is a table. it is the only table in the room": the table; the "in" before
    # "the room" asks nothing about what holds the table
    ctx = _room([FLOOR, (1, "table", (0.0, 0.0, 0.4), (1.2, 0.8, 0.8)),
                 (2, "cabinet", (3.0, 0.0, 0.5), (0.8, 0.5, 1.0)),
                 (3, "cup", (0.2, 0.0, 0.85), (0.1, 0.1, 0.1))])  # fmt: skip
    answer = REASONER.answer("the item is a table. it is the only table in the room.", ctx)
    assert answer.entity_ids == (1,), answer.explanation
    # the question whose clause ends on its cue still asks about the subject
    assert REASONER.answer("what is the cup on?", ctx).entity_ids == (1,)


def test_face_x_and_walk_to_the_one_on_the_right() -> None:
    # a couch against the north wall facing south; two armchairs beside it. Facing the
    # couch (from the south) the eastern chair is on the right
    ctx = _room([FLOOR, (1, "couch", (0.0, 3.0, 0.4), (2.0, 0.9, 0.8)),
                 (2, "chair", (-1.8, 2.8, 0.45), BOX),
                 (3, "chair", (1.8, 2.8, 0.45), BOX),
                 (4, "table", (0.0, 1.0, 0.3), (1.0, 0.6, 0.6))])  # fmt: skip
    answer = REASONER.answer("Face the couch and walk to the seat on the right next to it.", ctx)
    assert answer.entity_ids == (3,), answer.explanation
    assert "facing 'couch'" in answer.explanation


def test_the_closest_one_to_x_is_the_target_named_again() -> None:
    # "the chair is the closest one to the door": measured from the door, never from "one"
    ctx = _room([FLOOR, (1, "door", (3.9, 0.0, 1.0), (0.1, 0.9, 2.0)),
                 (2, "chair", (-2.0, 0.0, 0.45), (0.9, 0.9, 0.9)),
                 (3, "chair", (2.5, 0.5, 0.45), BOX)])  # fmt: skip
    answer = REASONER.answer("the chair is the closest one to the door.", ctx)
    assert answer.entity_ids == (3,), answer.explanation
    assert "closest 'door'" in answer.explanation


def test_which_way_a_thing_faces_is_not_where_it_stands() -> None:
    # "a chair facing left" says how it is turned; read as "on the left" it would pick
    # the western chair, while only the colour singles one out
    ctx = _room([FLOOR, (1, "chair", (-2.0, 0.0, 0.45), BOX, {"rgb": [30, 30, 30]}),
                 (2, "chair", (2.0, 0.0, 0.45), BOX, {"rgb": [200, 40, 40]})])  # fmt: skip
    for text in (
        "this is a red chair facing left.",
        "the red chair is facing to the left side",
        "this red chair is facing down and left.",
    ):
        answer = REASONER.answer(text, ctx)
        assert answer.entity_ids == (2,), answer.explanation
        assert "side" not in answer.explanation.splitlines()[0]


def test_a_row_of_like_things_is_one_of_them_beside_the_others() -> None:
    # three shoes in a row along the west wall, a fourth by the door: "in the row of
    # shoes" keeps the three, and the second from the left is counted among them only
    ctx = _room([FLOOR, (1, "shoe", (-3.0, -1.0, 0.05), (0.3, 0.1, 0.1)),
                 (2, "shoe", (-3.0, -0.6, 0.05), (0.3, 0.1, 0.1)),
                 (3, "shoe", (-3.0, -0.2, 0.05), (0.3, 0.1, 0.1)),
                 (4, "shoe", (3.0, 2.0, 0.05), (0.3, 0.1, 0.1)),
                 (5, "window", (-3.95, -0.6, 1.5), (0.1, 1.0, 1.0))])  # fmt: skip
    for text in (
        "facing the window, in the row of shoes the shoe second from the right",
        "facing the window, the shoe in a row of shoes, second from the right",
    ):
        answer = REASONER.answer(text, ctx)
        assert answer.entity_ids == (2,), answer.explanation
        assert "near 'shoe'" in answer.explanation


def test_a_shape_word_before_a_colour_and_a_noun_modifies_the_noun() -> None:
    # "next to the square gray armchair": "square" is no anchor of its own
    ctx = _room([FLOOR, (1, "table", (-2.0, 0.0, 0.4), (0.8, 0.8, 0.8)),
                 (2, "table", (2.0, 0.0, 0.4), (1.6, 1.0, 0.8)),
                 (3, "armchair", (-2.0, 1.0, 0.45), (0.9, 0.9, 0.9),
                  {"rgb": [128, 128, 128]})])  # fmt: skip
    answer = REASONER.answer("the table next to the square gray armchair", ctx)
    assert answer.entity_ids == (1,), answer.explanation
    assert "'square'" not in answer.explanation


def test_which_after_a_noun_is_no_head_of_a_compound() -> None:
    # "the door which opens into the bathroom": the door; "room" names no toilet
    # (read as "which" inside a toilet, the cabinet by the toilet would be the answer)
    ctx = _room([FLOOR, (1, "door", (3.9, 0.0, 1.0), (0.1, 0.9, 2.0)),
                 (2, "toilet", (-3.0, 2.0, 0.4), (0.5, 0.7, 0.8)),
                 (3, "cabinet", (-2.0, 1.0, 1.0), (1.5, 0.6, 2.0))])  # fmt: skip
    answer = REASONER.answer("it is the door which opens into the room.", ctx)
    assert answer.entity_ids == (1,), answer.explanation
    assert answer.explanation.startswith("read as: refer 'door'")
    assert "toilet" not in answer.explanation


def test_the_right_hand_one_of_two_is_a_side_not_a_relation() -> None:
    # facing the window (north), two doors side by side on the east wall and a cabinet
    # further east: "the right-hand of the two side-by-side doors" is the eastern door
    ctx = _room([FLOOR, (1, "window", (0.0, 3.9, 1.5), (2.0, 0.1, 1.0)),
                 (2, "door", (1.0, 3.8, 1.0), (0.9, 0.1, 2.0)),
                 (3, "door", (2.2, 3.8, 1.0), (0.9, 0.1, 2.0)),
                 (4, "cabinet", (3.4, 3.5, 1.0), (0.8, 0.5, 2.0))])  # fmt: skip
    for text in ("facing the window, the right-hand of the two side-by-side doors",
                 "facing the window, the right one of the two doors"):  # fmt: skip
        answer = REASONER.answer(text, ctx)
        assert answer.entity_ids == (3,), answer.explanation
    # with a preposition it stays a relation
    answer = REASONER.answer("facing the window, the cabinet to the right of the two doors", ctx)
    assert answer.entity_ids == (4,) and "right_of 'door'" in answer.explanation


def test_what_is_faced_is_the_phrase_after_facing_not_where_it_hangs() -> None:
    # a picture on the north-east of the room, the only wall entity in the south: facing
    # the picture, the eastern chair is on the right (facing the wall, the western one)
    ctx = _room([FLOOR, (1, "picture", (2.5, 3.9, 1.5), (0.8, 0.05, 0.6)),
                 (2, "wall", (0.0, -4.0, 1.5), (8.0, 0.1, 3.0)),
                 (3, "chair", (-2.0, 0.0, 0.45), BOX),
                 (4, "chair", (2.0, 0.0, 0.45), BOX)])  # fmt: skip
    answer = REASONER.answer("Facing the striped picture on the wall, the chair on the right.", ctx)
    assert answer.entity_ids == (4,), answer.explanation
    assert "facing 'picture'" in answer.explanation


def test_an_observer_who_stands_somewhere_and_looks_at_something_else() -> None:
    # the window in the north, the door in the east. From the room's centre facing the
    # window, monitor 5 (further east) is on the right; from the door looking at the
    # window, monitor 4 (far north) is
    ctx = _room([FLOOR, (1, "window", (0.0, 3.9, 1.5), (2.0, 0.1, 1.0)),
                 (2, "door", (3.9, 0.0, 1.0), (0.1, 0.9, 2.0)),
                 (4, "monitor", (-0.5, 3.5, 1.0), (0.5, 0.1, 0.4)),
                 (5, "monitor", (0.5, 0.5, 1.0), (0.5, 0.1, 0.4))])  # fmt: skip
    for text in ("looking at the window from the door, the monitor on the right",
                 "if standing at the door looking at the window, the right monitor"):  # fmt: skip
        answer = REASONER.answer(text, ctx)
        assert answer.entity_ids == (4,), answer.explanation
        assert "facing 'window'; from 'door'" in answer.explanation
    assert REASONER.answer("facing the window, the monitor on the right", ctx).entity_ids == (5,)


def test_a_viewpoint_clause_ends_after_to_your_right() -> None:
    # "... with the door to your right the chair on the left": the chair is the target
    ctx = _room([FLOOR, (1, "window", (0.0, 3.9, 1.5), (2.0, 0.1, 1.0)),
                 (2, "door", (3.9, 0.0, 1.0), (0.1, 0.9, 2.0)),
                 (3, "chair", (-2.0, 0.0, 0.45), BOX),
                 (4, "chair", (2.0, 0.0, 0.45), BOX)])  # fmt: skip
    text = "if you face the window with the door to your right the chair on the left"
    answer = REASONER.answer(text, ctx)
    assert answer.explanation.startswith("read as: refer 'chair'"), answer.explanation
    assert answer.entity_ids == (3,), answer.explanation


def test_an_anchor_whose_own_relation_fits_none_is_taken_alone() -> None:
    # no lamp stands on the table: "the table with a lamp on it" is still the table, and
    # the cup next to it is meant (dropping the relation would take the larger cup)
    ctx = _room([FLOOR, (1, "table", (0.0, 0.0, 0.4), (1.2, 0.8, 0.8), {"rgb": [120, 80, 40]}),
                 (2, "lamp", (3.0, 3.0, 0.8), (0.3, 0.3, 1.6)),
                 (3, "cup", (0.9, 0.0, 0.05), (0.1, 0.1, 0.1)),
                 (4, "cup", (-3.0, -3.0, 0.1), (0.2, 0.2, 0.2))])  # fmt: skip
    answer = REASONER.answer("the cup next to the table with a lamp on it", ctx)
    assert answer.entity_ids == (3,), answer.explanation
    assert "none fits its own relation" in answer.explanation
    # a description the scene contradicts (the table is brown) still leaves nothing
    answer = REASONER.answer("the cup next to the blue table", ctx)
    assert answer.entity_ids == (), answer.explanation


def test_words_before_a_head_noun_modify_it_and_a_compound_is_no_colour() -> None:
    # "the wood burning stove": a stove; "the coffee maker": a thing the room does not
    # hold, never a coffee-coloured target
    ctx = _room([FLOOR, (1, "stove", (3.0, 3.0, 0.5), (0.8, 0.8, 1.0)),
                 (2, "door", (3.9, 2.0, 1.0), (0.1, 0.9, 2.0)),
                 (3, "door", (-3.9, -2.0, 1.0), (0.1, 1.2, 2.1)),
                 (4, "trash can", (2.0, 3.5, 0.3), (0.4, 0.4, 0.6), {"rgb": [20, 20, 20]}),
                 (5, "trash can", (-2.0, 0.0, 0.3), (0.4, 0.4, 0.6),
                  {"rgb": [110, 70, 40]})])  # fmt: skip
    answer = REASONER.answer("the door closest to the wood burning stove", ctx)
    assert answer.entity_ids == (2,), answer.explanation
    assert "closest 'stove'" in answer.explanation
    answer = REASONER.answer("the trash can that is closest to the coffee maker", ctx)
    assert answer.explanation.startswith("read as: refer 'trash can'; closest 'coffee maker'")


def test_what_a_thing_has_not() -> None:
    # two tables hold a book; only the western one also holds a lamp
    ctx = _room([FLOOR, (1, "table", (-2.0, 0.0, 0.4), (1.0, 0.8, 0.8)),
                 (2, "table", (2.0, 0.0, 0.4), (1.0, 0.8, 0.8)),
                 (3, "table", (0.0, 3.0, 0.4), (1.6, 0.8, 0.8)),
                 (4, "book", (-2.2, 0.0, 0.85), (0.2, 0.3, 0.05)),
                 (5, "book", (2.2, 0.0, 0.85), (0.2, 0.3, 0.05)),
                 (6, "lamp", (-1.8, 0.1, 1.05), (0.2, 0.2, 0.5))])  # fmt: skip
    for text in ("the table that has a book on it, but no lamp",
                 "the table with a book on it and no lamp"):  # fmt: skip
        answer = REASONER.answer(text, ctx)
        assert answer.entity_ids == (2,), answer.explanation
        assert "not supports 'lamp'" in answer.explanation
    answer = REASONER.answer("the table that has no lamp on it", ctx)
    assert answer.explanation.startswith("read as: refer 'table'; not supports 'lamp'")


def test_the_middle_of_a_group_is_the_middle_one() -> None:
    # three plants in a row by the window, a fourth by the door
    ctx = _room([FLOOR, (1, "window", (0.0, 3.9, 1.5), (2.0, 0.1, 1.0)),
                 (2, "plant", (-1.0, 3.4, 0.4), (0.4, 0.4, 0.8)),
                 (3, "plant", (0.1, 3.4, 0.4), (0.4, 0.4, 0.8)),
                 (4, "plant", (1.0, 3.4, 0.4), (0.4, 0.4, 0.8)),
                 (5, "plant", (3.0, -3.0, 0.4), (0.4, 0.4, 0.8))])  # fmt: skip
    answer = REASONER.answer("the plant in the middle of the group next to the window", ctx)
    assert answer.entity_ids == (3,), answer.explanation
    assert "side middle" in answer.explanation


def test_a_word_before_a_part_names_no_anchor() -> None:
    # "the vertical side of the table": the table's side, not a thing called "vertical"
    ctx = _room([FLOOR, (1, "table", (0.0, 0.0, 0.4), (2.0, 0.8, 0.8)),
                 (2, "chair", (1.3, 0.0, 0.45), BOX),
                 (3, "chair", (-3.0, 3.0, 0.45), (0.7, 0.7, 0.9))])  # fmt: skip
    answer = REASONER.answer("the chair on the vertical side of the table", ctx)
    assert answer.entity_ids == (2,), answer.explanation
    assert "vertical" not in answer.explanation


def test_than_the_other_one_is_no_anchor() -> None:
    # "closer to the door than the other one": measured from the door only
    ctx = _room([FLOOR, (1, "door", (3.9, 0.0, 1.0), (0.1, 0.9, 2.0)),
                 (2, "table", (-2.0, 0.0, 0.4), (1.0, 1.0, 0.8)),
                 (3, "table", (2.0, 0.0, 0.4), (1.0, 1.0, 0.8)),
                 (4, "chair", (-2.0, 0.9, 0.45), BOX)])  # fmt: skip
    for text in ("the table closer to the door than the other one",
                 "it is the table nearer to the door than the others"):  # fmt: skip
        answer = REASONER.answer(text, ctx)
        assert answer.entity_ids == (3,), answer.explanation
        assert "'one'" not in answer.explanation and "'other" not in answer.explanation
    # an anchor the scene cannot place ("the entrance") leaves the comparison unanchored,
    # never measured from "the other one" (any entity: the table by the chair)
    answer = REASONER.answer("the table closer to the entrance than the other one", ctx)
    assert "'one'" not in answer.explanation, answer.explanation


def test_two_colours_joined_by_and_describe_one_thing() -> None:
    # "has a blue and grey item on it": both colours are the item's, none the chair's
    ctx = _room([FLOOR, (1, "chair", (-2.0, 0.0, 0.45), BOX, {"rgb": [110, 70, 40]}),
                 (2, "chair", (2.0, 0.0, 0.45), BOX, {"rgb": [115, 75, 45]}),
                 (3, "box", (2.0, 0.0, 1.0), (0.3, 0.3, 0.2),
                  {"rgb": [90, 100, 140]})])  # fmt: skip
    answer = REASONER.answer("the brown chair has a blue and grey box on it", ctx)
    assert answer.entity_ids == (2,), answer.explanation
    assert answer.explanation.startswith("read as: refer 'brown chair'; supports"), (
        answer.explanation
    )


def test_facing_x_with_ys_picks_among_the_ys() -> None:
    # "facing the wall with bags on it, it is the one on the left": one of the bags
    ctx = _room([FLOOR, (1, "wall", (0.0, 3.95, 1.25), (8.0, 0.1, 2.5)),
                 (2, "bag", (-1.0, 3.8, 1.5), (0.4, 0.2, 0.5)),
                 (3, "bag", (1.0, 3.8, 1.5), (0.4, 0.2, 0.5))])  # fmt: skip
    answer = REASONER.answer("Facing the wall with bags on it, it is the one on the left.", ctx)
    assert answer.entity_ids == (2,), answer.explanation
    assert "refer 'bag'" in answer.explanation and "facing 'wall'" in answer.explanation


def test_a_compound_s_last_noun_is_its_head_across_modifier_words() -> None:
    # "a hanging wall portrait picture", "the wall mounted shelf": pictures and shelves,
    # never the wall; "a black desk arm chair": a chair
    ctx = _room([FLOOR, (1, "wall", (0.0, 3.95, 1.25), (8.0, 0.1, 2.5)),
                 (2, "picture", (-1.0, 3.85, 1.6), (0.6, 0.05, 0.5)),
                 (3, "shelf", (1.5, 3.8, 1.5), (1.0, 0.3, 0.05)),
                 (4, "desk", (0.0, -3.0, 0.4), (1.4, 0.7, 0.8)),
                 (5, "chair", (0.0, -2.4, 0.45), BOX)])  # fmt: skip
    cases = {
        "this is a hanging wall portrait picture.": "picture",
        "the wall mounted shelf": "shelf",
        "a black desk arm chair": "black chair",
        # how far a thing reaches is no thing: "floor to ceiling curtains" are curtains
        "these are tan, floor to ceiling shelves.": "tan shelf",
        "wall-to-wall shelf": "shelf",
        # the head a WordNet noun for a kind here (shelves): "bookshelf"
        "the 3 tier wall mounted bookshelf": "bookshelf",
    }
    for text, category in cases.items():
        answer = REASONER.answer(text, ctx)
        assert answer.explanation.startswith(f"read as: refer '{category}'"), answer.explanation


def test_a_colour_and_a_noun_that_wordnet_joins_stay_a_colour_when_the_noun_names_a_kind() -> None:
    # WordNet knows "blue book" (an exam booklet): with books here it is a book that is blue
    ctx = _room([FLOOR, (1, "book", (-1.0, 0.0, 0.8), (0.3, 0.2, 0.05), {"rgb": [30, 50, 160]}),
                 (2, "book", (1.0, 0.0, 0.8), (0.4, 0.3, 0.06), {"rgb": [170, 40, 40]}),
                 (3, "bowl", (-1.3, 0.0, 0.8), (0.2, 0.2, 0.1)),
                 (4, "bowl", (1.3, 0.0, 0.8), (0.2, 0.2, 0.1))])  # fmt: skip
    answer = REASONER.answer("the blue book", ctx)
    assert answer.entity_ids == (1,), answer.explanation
    answer = REASONER.answer("the bowl closest to the blue book", ctx)
    assert answer.entity_ids == (3,), answer.explanation


def test_upper_left_is_the_leftmost_of_the_highest_level() -> None:
    # kitchen cabinets on the north wall, two levels: upper (2, 3) and lower (4, 5). Facing
    # the wall, "the upper left cabinet" is 2, the leftmost of the upper ones, neither the
    # highest alone (3, a little higher) nor the leftmost of all (4, a lower one, further
    # west); "the top right" / "the bottom left" read both words the same way
    ctx = _room([FLOOR, (1, "wall", (0.0, 3.95, 1.25), (8.0, 0.1, 2.5)),
                 (2, "cabinet", (-1.0, 3.6, 1.85), (0.8, 0.4, 0.8)),
                 (3, "cabinet", (0.5, 3.6, 1.95), (0.8, 0.4, 0.8)),
                 (4, "cabinet", (-2.0, 3.6, 0.45), (0.8, 0.6, 0.9)),
                 (5, "cabinet", (1.5, 3.6, 0.45), (0.8, 0.6, 0.9))])  # fmt: skip
    cases = {
        "facing the wall, the upper left cabinet": 2,
        "facing the wall, it is the cabinet on the top right": 3,
        "facing the wall, the cabinet on the bottom left": 4,
        "facing the wall, the highest cabinet": 3,
    }
    for text, expected in cases.items():
        answer = REASONER.answer(text, ctx)
        assert answer.entity_ids == (expected,), (text, answer.explanation)


def test_a_negation_ends_with_its_clause() -> None:
    # "the couch with no back, by the plant": by the plant, not away from it
    ctx = _room([FLOOR, (1, "plant", (2.5, 0.0, 0.5), (0.4, 0.4, 1.0)),
                 (2, "couch", (1.5, 0.0, 0.4), (0.8, 2.0, 0.8)),
                 (3, "couch", (-2.0, 0.0, 0.4), (0.8, 2.0, 0.8))])  # fmt: skip
    answer = REASONER.answer("The couch with no back, by the plant.", ctx)
    assert answer.entity_ids == (2,), answer.explanation
    answer = REASONER.answer("the couch that is not by the plant", ctx)
    assert answer.entity_ids == (3,), answer.explanation


def test_your_back_to_a_thing_stands_there_and_a_negated_side_keeps_the_others() -> None:
    # a window on the east wall, doors north and south of the room's middle: with your back
    # to the window you look west, and the northern door (2) is on your right; facing the
    # window it is on your left. "its back to the window" is how a thing faces: no observer
    ctx = _room([FLOOR, (1, "window", (3.95, 0.0, 1.4), (0.1, 1.6, 1.2)),
                 (2, "door", (0.0, 3.9, 1.0), (0.9, 0.1, 2.0)),
                 (3, "door", (0.0, -3.9, 1.0), (0.9, 0.1, 2.0)),
                 (4, "chair", (3.0, 0.5, 0.45), BOX)])  # fmt: skip
    cases = {
        "If your back is against the window, it is the door on the right.": (2,),
        "with my back to the window, the door on my left": (3,),
        "facing the window, the door on the right": (3,),
        "If your back is against the window, it is not the door to your right.": (3,),
        "facing the window, not the door on the left": (3,),
    }
    for text, expected in cases.items():
        answer = REASONER.answer(text, ctx)
        assert answer.entity_ids == expected, (text, answer.explanation)
    answer = REASONER.answer("the chair with its back to the window", ctx)
    assert "standing at" not in answer.explanation, answer.explanation


def test_it_is_the_n_of_another_kind_names_the_target() -> None:
    # "there is a bookshelf between two doors. it is the door on the left": a door; "this
    # is a door. it is the one on the left" and "... it is the door on the left" too
    ctx = _room([FLOOR, (1, "wall", (0.0, 3.95, 1.25), (8.0, 0.1, 2.5)),
                 (2, "bookshelf", (0.0, 3.7, 1.0), (1.0, 0.4, 2.0)),
                 (3, "door", (-1.5, 3.85, 1.0), (0.9, 0.1, 2.0)),
                 (4, "door", (1.5, 3.85, 1.0), (0.9, 0.1, 2.0))])  # fmt: skip
    cases = {
        "There is a bookshelf between two doors. It is the door on the left.": (3,),
        "this is a door. it is the one on the right.": (4,),
        "the bookshelf between the doors. its the bookshelf": (2,),
    }
    for text, expected in cases.items():
        answer = REASONER.answer(text, ctx)
        assert answer.entity_ids == expected, (text, answer.explanation)


def test_a_relation_after_what_a_thing_has_places_what_it_has() -> None:
    # "the side with chairs against the wall, the middle chair": chairs, not the wall;
    # "the table with chairs beside the cabinet": the table whose chairs stand by it
    ctx = _room([FLOOR, (1, "wall", (0.0, 3.95, 1.25), (8.0, 0.1, 2.5)),
                 (2, "chair", (-1.0, 3.5, 0.45), BOX), (3, "chair", (0.0, 3.5, 0.45), BOX),
                 (4, "chair", (1.0, 3.5, 0.45), BOX),
                 (5, "table", (0.0, 2.6, 0.4), (3.0, 1.0, 0.8)),
                 (6, "table", (0.0, -2.0, 0.4), (1.0, 1.0, 0.8)),
                 (7, "chair", (0.0, -2.8, 0.45), BOX),
                 (8, "cabinet", (1.8, 3.5, 0.5), (0.6, 0.5, 1.0))])  # fmt: skip
    answer = REASONER.answer("On the side with 3 chairs against the wall, the middle chair.", ctx)
    assert answer.explanation.startswith("read as: refer 'chair'"), answer.explanation
    answer = REASONER.answer("the table with chairs beside the cabinet", ctx)
    assert answer.entity_ids == (5,), answer.explanation
    assert "none fits its own relation" not in answer.explanation


def test_the_kind_a_one_is_of_named_again_takes_its_ordinal() -> None:
    # "one of many chairs ... it is the third chair from the left": the third, not the first;
    # "turn left" is which way one goes, not the side the chair is on
    ctx = _room([FLOOR, (1, "wall", (0.0, 3.95, 1.25), (8.0, 0.1, 2.5)),
                 *((k + 2, "chair", (-2.0 + k, 3.0, 0.45), BOX) for k in range(5))])  # fmt: skip
    text = "one of many chairs sits before the wall. it is the third chair from the left."
    answer = REASONER.answer(text, ctx)
    assert answer.entity_ids == (4,), answer.explanation
    answer = REASONER.answer("turn left and it is the chair on the right", ctx)
    assert answer.entity_ids == (6,), answer.explanation
    assert "side left" not in answer.explanation


def test_a_thing_said_to_be_beside_the_target_is_its_anchor() -> None:
    # "... in front of the desk is a chair": the desk the chair stands in front of (seen
    # from the room's middle, the desk is behind the chair), never the desk in front of
    # itself; "in front of it is a chair" the same
    ctx = _room([FLOOR, (1, "desk", (0.0, 3.5, 0.4), (1.2, 0.6, 0.8)),
                 (2, "chair", (0.0, 2.7, 0.45), BOX),
                 (3, "desk", (3.5, 0.0, 0.4), (0.6, 1.2, 0.8)),
                 (4, "lamp", (-3.0, -3.0, 0.8), (0.3, 0.3, 1.6))])  # fmt: skip
    for text in (
        "this is a desk. directly in front of the desk is a chair.",
        "the desk is by the wall. in front of it there is a chair.",
    ):
        answer = REASONER.answer(text, ctx)
        assert answer.entity_ids == (1,), (text, answer.explanation)
        assert "behind 'chair'" in answer.explanation, answer.explanation
    # the chair named again as the anchor of a clause about something else: "a lamp is
    # behind the chair" places the chair in front of the lamp
    for text in (
        "this is a chair. a lamp is behind the chair.",
        "this is a chair. there is a lamp behind the chair.",
    ):
        answer = REASONER.answer(text, ctx)
        assert "in_front_of 'lamp'" in answer.explanation, (text, answer.explanation)
    answer = REASONER.answer("the desk by the wall. the desk is left of the lamp.", ctx)
    assert "left_of 'lamp'" in answer.explanation, answer.explanation


def test_far_right_of_an_anchor_is_the_rightmost_of_those_right_of_it() -> None:
    # chairs along the south side of a table, seen from the room's middle (north of it):
    # "right of the table" holds 3 and 4; "to the right" takes the one closest to the
    # table, "to the far right" the rightmost
    ctx = _room([FLOOR, (1, "table", (0.0, -2.0, 0.4), (1.0, 1.0, 0.8)),
                 (2, "chair", (1.0, -2.0, 0.45), BOX), (3, "chair", (-1.0, -2.0, 0.45), BOX),
                 (4, "chair", (-2.2, -2.0, 0.45), BOX)])  # fmt: skip
    near = REASONER.answer("the chair to the right of the table", ctx)
    far = REASONER.answer("the chair to the far right of the table", ctx)
    way = REASONER.answer("the chair all the way to the right of the table", ctx)
    assert (near.entity_ids, far.entity_ids, way.entity_ids) == ((3,), (4,), (4,))


def test_an_absent_window_is_where_its_curtains_hang() -> None:
    # no window in the objects, curtains over one: "closest to the window" measures to the
    # curtains, as the knowledge table says what curtains are (hung over a window)
    ctx = _room([FLOOR, (1, "curtain", (3.9, 2.0, 1.5), (0.1, 1.5, 2.0)),
                 (2, "nightstand", (3.4, 2.0, 0.3), (0.5, 0.5, 0.6)),
                 (3, "nightstand", (-3.0, -2.0, 0.35), (0.6, 0.6, 0.7))])  # fmt: skip
    answer = REASONER.answer("The nightstand closest to the window.", ctx)
    assert answer.entity_ids == (2,), answer.explanation
    assert "anchor 'window' read as curtain (by 'curtain: a fabric panel hung over a window')" in (
        answer.explanation
    )


def test_the_height_of_a_shelf_picks_among_what_is_on_it() -> None:
    # one bookcase, books on three of its shelves: "the books on the highest shelf" are the
    # highest books, not the books on the highest bookcase
    ctx = _room([FLOOR, (1, "bookshelf", (0.0, 3.7, 1.0), (1.2, 0.4, 2.0)),
                 (2, "books", (0.0, 3.7, 0.35), (1.0, 0.3, 0.25)),
                 (3, "books", (0.0, 3.7, 1.05), (1.0, 0.3, 0.25)),
                 (4, "books", (0.0, 3.7, 1.75), (1.0, 0.3, 0.25))])  # fmt: skip
    cases = {
        "The books that are on the highest shelf": (4,),
        "the books on the bottom shelf of the bookcase": (2,),
    }
    for text, expected in cases.items():
        answer = REASONER.answer(text, ctx)
        assert answer.entity_ids == expected, (text, answer.explanation)
    # where the scene stores no bookcase, the height still picks among the books
    books = _room([FLOOR, *((k, "books", (0.0, 3.7, z), (1.0, 0.3, 0.25))
                            for k, z in ((2, 0.35), (3, 1.05), (4, 1.75)))])  # fmt: skip
    answer = REASONER.answer("the books on the top shelf", books)
    assert answer.entity_ids == (4,), answer.explanation


def test_there_is_one_to_the_left_places_a_neighbour_not_the_target() -> None:
    # chairs in a row north of the room's middle, seen from it: "there is a chair to the
    # left" says the target has one on its left, not that it is the leftmost
    ctx = _room([FLOOR, (1, "table", (0.0, 3.0, 0.4), (3.0, 0.8, 0.8)),
                 (2, "chair", (-1.0, 2.3, 0.45), BOX), (3, "chair", (0.0, 2.3, 0.45), BOX),
                 (4, "chair", (1.0, 2.3, 0.45), BOX)])  # fmt: skip
    text = "the chair is at the table. there is a chair to the left, and one to the right of it."
    answer = REASONER.answer(text, ctx)
    assert answer.entity_ids == (3,), answer.explanation
    assert "side left" not in answer.explanation.splitlines()[0]


def test_an_anchor_one_is_another_of_the_targets_kind() -> None:
    # three shelves far apart, the tallest also the largest: "a large shelf next to the
    # tall one" is another shelf than the tall one (nothing is stored near it), never the
    # tallest thing of the room whatever its kind, nor the tall shelf itself
    ctx = _room([FLOOR, (1, "shelf", (-2.5, 3.0, 0.6), (0.6, 1.3, 1.2)),
                 (2, "shelf", (2.5, -3.0, 0.45), (1.0, 0.4, 0.9)),
                 (3, "shelf", (2.5, 3.0, 0.4), (0.35, 0.35, 0.8)),
                 (4, "wardrobe", (-3.5, -3.0, 1.0), (0.6, 1.0, 2.0))])  # fmt: skip
    answer = REASONER.answer("a large shelf next to the tall skinny one", ctx)
    assert "near 'one'" in answer.explanation, answer.explanation
    assert 'filter_category(v0, "wardrobe")' not in answer.explanation
    assert answer.entity_ids == (2,), answer.explanation


def test_an_anchor_named_by_meaning_is_not_the_targets_own_kind() -> None:
    # a recliner is a kind of chair (WordNet): "the chair closest to the recliner" is the
    # chair by the massage chair, not the chair closest to another chair
    ctx = _room([FLOOR, (1, "massage chair", (0.0, 0.0, 0.5), (0.9, 0.9, 1.0)),
                 (2, "chair", (1.4, 0.0, 0.45), BOX), (3, "chair", (-3.0, 3.0, 0.45), BOX),
                 (4, "chair", (-3.0, 2.4, 0.45), BOX)])  # fmt: skip
    answer = REASONER.answer("the chair closest to the recliner", ctx)
    assert answer.entity_ids == (2,), answer.explanation
    assert 'filter_category(v0, "massage chair")' in answer.explanation


def test_long_wide_and_narrow_rank_by_the_longer_side_of_the_footprint() -> None:
    # two tables of one height: a long narrow one (2.4 x 0.6) and a square one (1.2 x 1.2,
    # the larger by volume); a narrow window and a wide one
    ctx = _room([FLOOR, (1, "table", (-2.0, 0.0, 0.4), (0.6, 2.4, 0.8)),
                 (2, "table", (2.0, 0.0, 0.4), (1.2, 1.2, 0.8)),
                 (3, "window", (0.0, 3.9, 1.5), (0.5, 0.1, 1.2)),
                 (4, "window", (2.0, 3.9, 1.5), (1.8, 0.1, 1.0))])  # fmt: skip
    for text in ("the long table", "the longest table", "the wider table"):
        answer = REASONER.answer(text, ctx)
        assert answer.entity_ids == (1,), text
        assert Metric.LENGTH in {s.metric for s in answer.program.steps}, text
    assert REASONER.answer("the large table", ctx).entity_ids == (2,)
    assert REASONER.answer("the narrow window", ctx).entity_ids == (3,)
    assert REASONER.answer("the wide window", ctx).entity_ids == (4,)


def test_a_size_said_with_a_side_is_the_extreme_of_those_on_that_side() -> None:
    # four lamps along the north wall, seen facing the window there: the two on the left
    # are 1.5 and 1.0 m tall, the two on the right 1.8 and 0.5 m; "the tall lamp on the
    # left" is the taller of the left two, not the tallest lamp (which is on the right)
    ctx = _room([FLOOR, (1, "window", (0.0, 3.9, 1.5), (1.2, 0.1, 1.0)),
                 (2, "lamp", (-3.0, 3.0, 0.75), (0.3, 0.3, 1.5)),
                 (3, "lamp", (-1.0, 3.0, 0.5), (0.3, 0.3, 1.0)),
                 (4, "lamp", (1.0, 3.0, 0.9), (0.3, 0.3, 1.8)),
                 (5, "lamp", (3.0, 3.0, 0.25), (0.3, 0.3, 0.5))])  # fmt: skip
    ask = REASONER.answer
    assert ask("facing the window, the tall lamp on the left", ctx).entity_ids == (2,)
    assert ask("facing the window, the short lamp on the left", ctx).entity_ids == (3,)
    assert ask("facing the window, the smaller lamp on the right", ctx).entity_ids == (5,)
    assert ask("facing the window, the tallest lamp", ctx).entity_ids == (4,)
