"""General rules of how people refer to things (Nr3D-style phrasings), on sentences written
for these tests: viewpoint clauses without a comma, ...

The room is the hand-made one of ``conftest.py``: a table (1) with cups (2, 4) and a box
(3) on it, chairs west (5) and east (6) of the table and a tall one in the far corner (7),
a door (8) on the north wall, a lamp (9) in the south-east, a couch (10) south-west.
"""

from __future__ import annotations

import pytest

from causalsplat.reason import SceneContext
from causalsplat.reason._text import tokenize
from causalsplat.reason.embed import embeddings_available
from causalsplat.reason.offline import OfflineReasoner
from causalsplat.reason.parse import _split_viewpoint
from queries import Metric, Op

REASONER = OfflineReasoner(embeddings=False)


def ask(ctx: SceneContext, text: str) -> tuple[int, ...]:
    return REASONER.answer(text, ctx).entity_ids


def split(text: str) -> tuple[str, str]:
    view, main = _split_viewpoint(tokenize(text))
    return " ".join(view), " ".join(main)


@pytest.mark.parametrize(
    ("text", "view", "main"),
    [
        # no comma: the main clause opens with a verb, a pronoun or a new noun phrase
        ("when facing the sofa pick the lamp on the right", "when facing the sofa",
         "pick the lamp on the right"),
        ("facing the window it is the plant on the left", "facing the window",
         "it is the plant on the left"),
        ("facing the oven the cabinet in the top corner", "facing the oven",
         "the cabinet in the top corner"),
        ("standing by the door looking at the desks the correct one is on the left",
         "standing by the door looking at the desks", "the correct one is on the left"),
        # after the main clause, opened by a subordinator
        ("the third picture from the right when you face the bed",
         "when you face the bed", "the third picture from the right"),
        # one sentence, then another
        ("face the sink. the towel you want is on the right", "face the sink .",
         "the towel you want is on the right"),
        # "from X," opening the sentence: standing at X
        ("from the doorway, the nightstand on the right", "from the doorway ,",
         "the nightstand on the right"),
    ],
)  # fmt: skip
def test_viewpoint_clauses(text: str, view: str, main: str) -> None:
    assert split(text) == (view, main)


@pytest.mark.parametrize(
    "text",
    [
        "the lamp standing next to the bed, near the window",  # a participle, not the observer
        "you are looking for the small stool",  # searching, not a viewpoint
        "look at the picture right above the seat",  # nothing left for a main clause
        "the second from the left, by the door",  # "from" inside the main clause
    ],
)
def test_no_viewpoint_clause(text: str) -> None:
    assert split(text)[0] == ""


def test_viewpoint_without_comma_keeps_the_target(room: SceneContext) -> None:
    # Facing the table from the centre (3, 2): right is north-west, so chair 5 (west).
    ins = REASONER.parse("when facing the table choose the chair on the right", room)
    assert ins.target is not None and ins.target.categories == ("chair",)
    assert ins.viewpoint is not None and ins.viewpoint.categories == ("table",)
    assert ask(room, "facing the table it is the chair to the right of it") == (5,)


def test_standing_at_the_front_of_something_faces_it(room: SceneContext) -> None:
    ins = REASONER.parse("the chair on the left if you are standing in front of the table", room)
    assert ins.viewpoint is not None and not ins.standing_at
    ins = REASONER.parse("if you are standing at the door, the chair on the left", room)
    assert ins.viewpoint is not None and ins.standing_at


def test_a_later_sentence_is_not_the_subject_of_the_one(room: SceneContext) -> None:
    ins = REASONER.parse("facing the table the correct one is on the left. a lamp is by it", room)
    assert ins.target is not None and ins.target.categories == ("table",)


# Places in the room. Chairs 5 (1.25, 1.45), 6 (3.85, 1.45), 7 (5.4, 3.2); the scene
# centre is (3, 2): horizontally 1.83, 1.01 and 2.68 from it. Nearest other chair: 5 is
# 2.6 from 6, 6 and 7 are 2.34 apart.
@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("the chair in the corner", (7,)),
        ("the chair in the corner of the room", (7,)),
        ("pick the chair that is in the middle of the room", (6,)),
        ("the chair by itself", (5,)),
        ("the chair that sits alone", (5,)),
        ("choose the chair that is on its own", (5,)),
        ("choose the chair that is sitting by itself", (5,)),
        ("the chairs standing by themselves", (5,)),
    ],
)
def test_places_in_the_room(room: SceneContext, text: str, expected: tuple[int, ...]) -> None:
    assert ask(room, text) == expected


def test_places_are_not_relations_to_other_things(room: SceneContext) -> None:
    # "in the middle of the lamp and the couch" is still "between"; "in the corner of the
    # table" is no place in the room
    ins = REASONER.parse("the chair in the middle of the lamp and the couch", room)
    assert ins.target is not None and ins.target.place is None
    assert [c.kind for c in ins.target.constraints] == ["between"]
    ins = REASONER.parse("the cup in the corner of the table", room)
    assert ins.target is not None and ins.target.place is None


def test_a_side_of_a_corner_keeps_the_corner(room: SceneContext) -> None:
    # "in the back right corner": in a corner, and the corner on the right
    for text, side in (
        ("the chair in the back right corner of the room", "right"),
        ("the chair in the left corner", "left"),
    ):
        ins = REASONER.parse(text, room)
        assert ins.target is not None and ins.target.place == "corner"
        assert ins.target.side == side


def test_not_in_the_corner(room: SceneContext) -> None:
    ins = REASONER.parse("the chair that is not in the corner", room)
    assert ins.target is not None and ins.target.place == "corner" and ins.target.place_negated
    assert ask(room, "the chair that is not in the corner") in ((5,), (6,))


@pytest.mark.parametrize(
    ("text", "kind"),
    [
        ("the chair in the dark corner", "chair"),
        ("the cup on the table in a small room", "cup"),
        ("the chair next to the tall man", "chair"),
        ("the lamp next to the person in blue", "lamp"),
        ("the couch beside a woman in a red dress", "couch"),
    ],
)
def test_a_place_or_person_keeps_its_own_modifiers(
    room: SceneContext, text: str, kind: str
) -> None:
    # "dark", "small", "tall", "in blue" describe the corner, the room, the man and the
    # person (none of them an entity here), not the target: nothing contradicts it
    ins = REASONER.parse(text, room)
    assert ins.target is not None and ins.target.categories == (kind,)
    assert ins.target.attributes == () and ins.target.extremes == ()
    assert REASONER.answer(text, room).entity_ids != ()


def test_a_target_keeps_the_modifiers_said_of_it(room: SceneContext) -> None:
    ins = REASONER.parse("the black chair in the corner", room)
    assert ins.target is not None and ins.target.attributes == ("black",)
    assert ins.target.place == "corner"
    ins = REASONER.parse("the chair in black", room)
    assert ins.target is not None and ins.target.attributes == ("black",)


Box = tuple[int, str, tuple[float, float, float], tuple[float, float, float]]


def _scene(objects: list[Box]) -> SceneContext:
    from causalsplat.objects import objects_to_scene_graph, parse_objects

    doc = {
        "scene_id": "rules",
        "objects": [
            {"id": i, "label": label, "center": list(c), "size": list(s)}
            for i, label, c, s in objects
        ],
    }
    return SceneContext(objects_to_scene_graph(parse_objects(doc)))


#: A kitchen with a stove (no "oven" label), a bookshelf (no "bookcase"), two stools and
#: two chairs; stool 3 stands by the stove, stool 4 by the bookshelf.
KITCHEN: list[Box] = [
    (1, "stove", (0.0, 0.0, 0.45), (0.8, 0.7, 0.9)),
    (2, "bookshelf", (6.0, 0.0, 1.0), (1.0, 0.4, 2.0)),
    (3, "stool", (1.0, 0.2, 0.35), (0.4, 0.4, 0.7)),
    (4, "stool", (5.0, 0.2, 0.35), (0.4, 0.4, 0.7)),
    (5, "monitor", (3.0, 3.0, 1.0), (0.6, 0.2, 0.4)),
    (6, "chair", (2.6, 3.6, 0.45), (0.5, 0.5, 0.9)),
    (7, "chair", (5.5, 3.6, 0.45), (0.5, 0.5, 0.9)),
]


def test_a_compound_that_names_nothing_leaves_its_head() -> None:
    # WordNet knows "computer monitor", whose sense reaches no category here; its head
    # "monitor" names one
    ins = REASONER.parse("the chair closest to the computer monitor", _scene(KITCHEN))
    assert ins.target is not None
    (relation,) = ins.target.constraints
    assert relation.anchors[0].categories == ("monitor",)
    assert ask(_scene(KITCHEN), "the chair closest to the computer monitor") == (6,)


@pytest.mark.skipif(not embeddings_available(), reason="embed extra not installed")
def test_an_unnamed_anchor_is_grounded_by_meaning() -> None:
    reasoner = OfflineReasoner(embeddings=True)
    ctx = _scene(KITCHEN)
    assert reasoner.answer("the stool next to the oven", ctx).entity_ids == (3,)
    assert reasoner.answer("the stool by the bookcase", ctx).entity_ids == (4,)
    # a room is no anchor, nor is an anchor that means the target itself
    grounded = reasoner.ground("the stool in the kitchen", ctx)
    assert grounded.anchors == ()
    grounded = reasoner.ground("the stool under the seat", ctx)
    assert all("stool" not in g.chosen for _, g in grounded.anchors)


def test_a_viewpoint_phrase_with_its_own_side_is_read_from_the_default_observer() -> None:
    # the viewpoint ("the room with the sink to your right") has a side of its own; it is
    # placed as seen from the scene centre instead of from itself (this looped forever)
    boxes: list[Box] = [
        (1, "sink", (0.0, 0.0, 0.45), (0.8, 0.7, 0.9)),
        (2, "towel", (-1.0, 0.5, 1.0), (0.3, 0.1, 0.5)),
        (3, "towel", (1.0, 0.5, 1.0), (0.3, 0.1, 0.5)),
        (4, "window", (0.0, 3.0, 1.5), (1.0, 0.1, 1.0)),
    ]
    text = (
        "If you face the room with the sink to your right the towel is the first on the left "
        "of the sink."
    )
    assert ask(_scene(boxes), text) in ((2,), (3,))


def test_a_viewpoint_names_the_target_when_the_main_clause_names_nothing() -> None:
    # Nr3D's "facing the chairs, choose the second from the left": one of the chairs, and
    # the words that single it out are kept although no noun follows them
    scene = _scene(KITCHEN)
    left = ask(scene, "facing the chairs, left")
    second = ask(scene, "facing the chairs, choose the second from the left")
    assert {left, second} == {(6,), (7,)}
    # a question keeps asking about anything
    ins = REASONER.parse("facing the chairs, what is on the left?", scene)
    assert ins.target is not None and ins.target.categories == ()


def test_the_one_among_counted_seats_is_one_of_them() -> None:
    # two chairs face a wall (y = 3); a third stands behind them. Sitting in them facing
    # the wall, x grows to the right: "the one on the left" is the chair at x = 0, one of
    # the two chairs, not the wall faced
    scene = _scene([(1, "wall", (1.0, 3.0, 1.2), (6.0, 0.1, 2.4)),
                    (2, "chair", (0.0, 1.0, 0.45), (0.5, 0.5, 0.9)),
                    (3, "chair", (1.0, 1.0, 0.45), (0.5, 0.5, 0.9)),
                    (4, "chair", (0.5, -2.0, 0.45), (0.5, 0.5, 0.9))])  # fmt: skip
    text = "Imagine you're sitting in the two chairs facing the wall. Choose the one on the left."
    assert ask(scene, text) == (2,)
    assert ask(scene, text.replace("left", "right")) == (3,)
    # one seat: "the one" is still of what is faced
    ins = REASONER.parse("sitting in the chair facing the walls, the one on the left", scene)
    assert ins.target is not None and ins.target.categories == ("wall",)


def test_look_at_names_what_is_sought() -> None:
    scene = _scene(KITCHEN)
    assert ask(scene, "look at the chair closest to the monitor") == (6,)
    assert ask(scene, "please look at the stool by the bookshelf") == (4,)
    # "at" elsewhere is still where a thing is
    ins = REASONER.parse("the stool at the stove", scene)
    assert ins.target is not None and [c.kind for c in ins.target.constraints] == ["near"]


def test_on_the_same_side_as_a_thing_is_beside_it() -> None:
    # the stools stand one by the stove, one by the bookshelf, on the kitchen's two sides
    scene = _scene(KITCHEN)
    assert ask(scene, "the stool on the same side as the stove") == (3,)
    assert ask(scene, "same side of the room as the bookshelf is, the stool") == (4,)
    assert ask(scene, "the stool, on the same wall as where the bookshelf is") == (4,)


def test_high_and_low_rank_by_height() -> None:
    scene = _scene([(1, "wall", (0.0, 2.0, 1.2), (6.0, 0.1, 2.4)),
                    (2, "lamp", (-1.0, 1.9, 2.0), (0.3, 0.2, 0.3)),
                    (3, "lamp", (1.0, 1.9, 0.5), (0.3, 0.2, 0.3)),
                    (4, "mirror", (-1.6, 1.9, 1.4), (0.6, 0.1, 0.8))])  # fmt: skip
    assert ask(scene, "The lamp high on the wall, next to the mirror.") == (2,)
    assert ask(scene, "the lamp low on the wall") == (3,)


def test_relations_joined_by_and_share_their_anchor() -> None:
    # a door left of the armchair, one in front of it, one both: "to the left of and in
    # front of" asks both of the armchair, not only the last
    scene = _scene([(1, "armchair", (0.0, 0.0, 0.45), (0.8, 0.8, 0.9)),
                    (2, "door", (-2.0, 0.0, 1.0), (0.1, 0.9, 2.0)),
                    (3, "door", (0.0, -2.0, 1.0), (0.9, 0.1, 2.0)),
                    (4, "door", (-1.5, -1.5, 1.0), (0.9, 0.1, 2.0))])  # fmt: skip
    ins = REASONER.parse("a door to the left of and in front of the armchair", scene)
    assert ins.target is not None
    kinds = [(c.kind, c.anchors[0].categories) for c in ins.target.constraints]
    assert kinds == [("left_of", ("armchair",)), ("in_front_of", ("armchair",))]
    # "with" and "has" join no place
    ins = REASONER.parse("a door with and next to the armchair", scene)
    assert ins.target is not None and [c.kind for c in ins.target.constraints] == ["near"]


def test_anchors_joined_by_and_are_both_anchors() -> None:
    scene = _scene(KITCHEN)

    def relations(text: str) -> list[tuple[str, tuple[str, ...]]]:
        ins = REASONER.parse(text, scene)
        assert ins.target is not None
        return [(c.kind, c.anchors[0].categories) for c in ins.target.constraints]

    # the first named stays the last relation (its anchor breaks ties)
    assert relations("the stool next to the stove and the monitor.") == [
        ("near", ("monitor",)), ("near", ("stove",))]  # fmt: skip
    # a new clause after "and" is no second anchor
    near = [r for r in relations("the stool next to the stove and the monitor is on the wall")
            if r[0] == "near"]  # fmt: skip
    assert near == [("near", ("stove",))]
    # "between" takes its two anchors as before
    assert relations("the stool between the stove and the bookshelf")[0][0] == "between"


def test_not_another_thing_denies_the_relation_of_it() -> None:
    # the larger plant stands on the table, the other on a cabinet by the window; the
    # scene has no windowsill: "..., not the table" still says which plant
    scene = _scene([(1, "table", (0.0, 0.0, 0.4), (1.2, 0.8, 0.8)),
                    (2, "plant", (0.0, 0.0, 1.0), (0.4, 0.4, 0.4)),
                    (3, "cabinet", (3.0, 2.0, 0.5), (0.8, 0.5, 1.0)),
                    (4, "plant", (3.0, 2.0, 1.15), (0.3, 0.3, 0.3))])  # fmt: skip
    assert ask(scene, "This plant is on the windowsill, NOT the table.") == (4,)
    # of the target's own kind it says which target, as before
    ins = REASONER.parse("the plant on the cabinet, not the one on the table", scene)
    assert ins.target is not None
    first = ins.target.constraints[0]
    assert (first.kind, first.negated, first.anchors[0].categories) == (
        "supported_by", False, ("cabinet",))  # fmt: skip


def test_a_thing_facing_another_is_turned_to_it() -> None:
    # chair 7 stands nearer the bookshelf than chair 6: "it is facing the bookshelf" says
    # which chair, read as the closest to it
    scene = _scene(KITCHEN)
    assert ask(scene, "this is a chair. it is facing the bookshelf.") == (7,)
    assert ask(scene, "the chair that faces towards the bookshelf") == (7,)
    # the observer facing a thing is a viewpoint, no relation of the target
    for text in ("if you are facing the bookshelf, the chair on the left",
                 "when you're facing the bookshelf it is the chair on the left"):  # fmt: skip
        ins = REASONER.parse(text, scene)
        assert ins.target is not None
        assert "closest" not in [c.kind for c in ins.target.constraints], text


def test_on_the_other_side_of_a_thing_is_across_from_it() -> None:
    # stool 3 stands by the stove, stool 4 across the kitchen from it
    scene = _scene(KITCHEN)
    ins = REASONER.parse("the stool on the other side of the stove", scene)
    assert ins.target is not None and [c.kind for c in ins.target.constraints] == ["opposite"]
    # the other side of the room is a place, no relation to a room
    ins = REASONER.parse("the stool on the other side of the room", scene)
    assert ins.target is not None and "opposite" not in [c.kind for c in ins.target.constraints]


@pytest.mark.parametrize(
    ("text", "kinds"),
    [("the stool on the long side of the stove", ["near"]),
     ("the stool at the side of the stove", ["near"]),
     ("the stool on the far side of the stove", ["behind"]),
     ("the stool on the near side of the stove", ["in_front_of"]),
     ("the stool on the left side of the stove", ["left_of"]),
     ("the stool on the stove", ["supported_by"])],
)  # fmt: skip
def test_a_side_of_a_thing_is_beside_it_not_on_it(text: str, kinds: list[str]) -> None:
    # "on the long side of the table" places a chair by the table, never on it; its far
    # and near sides are behind and in front of it as the observer sees it
    ins = REASONER.parse(text, _scene(KITCHEN))
    assert ins.target is not None and [c.kind for c in ins.target.constraints] == kinds
    # the side of the room is a place, no relation to a room
    ins = REASONER.parse("the stool on the far side of the room", _scene(KITCHEN))
    assert ins.target is not None and not ins.target.constraints


#: An apartment: a bathroom (toilet, bathtub) in the west, a kitchen (stove, fridge) in
#: the east, a door and a towel at each.
APARTMENT: list[Box] = [
    (1, "toilet", (-4.0, 0.0, 0.4), (0.4, 0.7, 0.8)),
    (2, "bathtub", (-4.5, 2.0, 0.3), (0.8, 1.6, 0.6)),
    (3, "stove", (4.0, 0.0, 0.45), (0.8, 0.7, 0.9)),
    (4, "refrigerator", (4.5, 2.0, 0.9), (0.8, 0.7, 1.8)),
    (5, "door", (4.0, -1.5, 1.0), (0.9, 0.1, 2.0)),
    (6, "door", (-3.0, -1.5, 1.0), (0.9, 0.1, 2.0)),
    (7, "towel", (-3.3, -1.3, 1.1), (0.4, 0.1, 0.6)),
    (8, "towel", (3.7, -1.3, 1.1), (0.4, 0.1, 0.6)),
    (9, "kitchen cabinets", (4.0, 1.0, 2.0), (1.0, 0.4, 0.8)),
    (10, "kitchen cabinets", (-1.0, 3.0, 2.0), (1.0, 0.4, 0.8)),
]  # fmt: skip


@pytest.mark.parametrize(
    ("text", "expected"),
    [("the bathroom door", (6,)), ("the kitchen door", (5,)),
     ("the door to the bathroom", (6,)), ("the door that opens into the kitchen", (5,)),
     ("the white bathroom door", (6,)), ("the towel by the bathroom door", (7,))],
)  # fmt: skip
def test_a_room_before_a_noun_or_after_to_says_where_it_is(
    text: str, expected: tuple[int, ...]
) -> None:
    # a room names no entity, but what is found only there tells where it is: "the
    # bathroom door" is the door by the toilet and bathtub, not a kind of door
    assert ask(_scene(APARTMENT), text) == expected


def test_a_room_no_scene_name_holds_is_what_is_found_only_there() -> None:
    # without kitchen cabinets nothing here is named for the kitchen: the knowledge
    # table's stove and refrigerator (found in the kitchen only) stand for it
    scene = _scene([b for b in APARTMENT if b[1] != "kitchen cabinets"])
    assert ask(scene, "the kitchen door") == (5,)
    assert ask(scene, "the towel nearest the kitchen") == (8,)
    answer = REASONER.answer("the door to the kitchen", scene)
    assert answer.entity_ids == (5,) and "found in the kitchen" in answer.explanation


def test_a_room_that_is_part_of_a_name_stays_the_name() -> None:
    # "kitchen cabinets" is what the scene calls them; "the kitchen cabinets by the
    # bathtub" is the one there, not the kitchen's
    scene = _scene(APARTMENT)
    assert ask(scene, "the kitchen cabinets closest to the bathtub") == (10,)
    ins = REASONER.parse("the kitchen cabinets", scene)
    assert ins.target is not None and not ins.target.constraints


def test_facing_several_things_faces_the_one_the_target_is_by() -> None:
    # windows on the north and south walls; the monitors stand by the south one. Facing
    # "the windows" is facing the south window (looking -y: +x is on the left), not the
    # middle of the room between the two
    boxes: list[Box] = [
        (1, "window", (0.0, 3.0, 1.5), (1.2, 0.1, 1.2)),
        (2, "window", (0.4, -3.0, 1.5), (1.2, 0.1, 1.2)),
        (3, "monitor", (-0.6, -2.0, 1.0), (0.5, 0.2, 0.4)),
        (4, "monitor", (0.0, -2.0, 1.0), (0.5, 0.2, 0.4)),
        (5, "monitor", (0.6, -2.0, 1.0), (0.5, 0.2, 0.4)),
        (6, "desk", (0.0, -2.1, 0.4), (2.0, 0.8, 0.8)),
    ]
    scene = _scene(boxes)
    assert ask(scene, "facing the windows, the monitor on the left") == (5,)
    assert ask(scene, "the second monitor from the right when facing the windows") == (4,)
    assert ask(scene, "facing the windows, the monitor on the right") == (3,)
    # a group the target belongs to is faced as a whole: from the room's middle
    assert ask(scene, "facing the monitors, the one on the left") == (5,)


def test_a_negated_relation_every_candidate_meets_takes_the_farthest() -> None:
    # both chairs stand at the desk; "not at the desk" then means the one farther from it
    boxes: list[Box] = [
        (1, "desk", (0.0, 0.0, 0.4), (1.6, 0.8, 0.8)),
        (2, "chair", (0.3, 0.6, 0.45), (0.5, 0.5, 0.9)),
        (3, "chair", (1.1, 0.7, 0.45), (0.5, 0.5, 0.9)),
    ]
    scene = _scene(boxes)
    assert ask(scene, "the chair next to the desk") == (2,)
    assert ask(scene, "the chair that is not next to the desk") == (3,)


@pytest.mark.parametrize(
    ("text", "expected"),
    [("the stool closes to the bookshelf", (4,)), ("the stool closes to the stove", (3,)),
     ("the stool with its back to the bookshelf", (4,)),
     ("the stool that has its back turned to the stove", (3,))],
)  # fmt: skip
def test_closes_to_and_a_back_turned_to_a_thing_are_by_it(
    text: str, expected: tuple[int, ...]
) -> None:
    # "closes to" is a slip for "closest to"; a seat with its back to the wall is by it
    assert ask(_scene(KITCHEN), text) == expected


def test_a_colour_and_another_adjective_describe_one_thing() -> None:
    # "the white and open door": one door, white and open, the anchor of the relation;
    # the target is neither white nor without its relation
    ins = REASONER.parse(
        "the chair left of the white and open door",
        _scene([*APARTMENT, (11, "chair", (0.0, 0.0, 0.45), (0.5, 0.5, 0.9))]),
    )
    assert ins.target is not None and ins.target.attributes == ()
    (relation,) = ins.target.constraints
    assert relation.kind == "left_of" and relation.anchors[0].attributes == ("white",)
    assert relation.anchors[0].categories == ("door",)


@pytest.mark.parametrize(
    "text",
    ["the chair in the corner", "the chair on the corner of the room",
     "the chair is on the northeast corner of the room", "the chair at the back corner"],
)  # fmt: skip
def test_on_a_corner_of_the_room_is_in_the_corner(text: str) -> None:
    boxes: list[Box] = [
        (1, "table", (3.0, 3.0, 0.4), (1.6, 1.0, 0.8)),
        (2, "chair", (0.3, 0.3, 0.45), (0.5, 0.5, 0.9)),
        (3, "chair", (3.0, 2.2, 0.45), (0.6, 0.6, 1.0)),  # the larger one
        (4, "shelf", (5.7, 5.7, 1.0), (0.6, 0.6, 2.0)),
    ]
    assert ask(_scene(boxes), text) == (2,)


def test_closest_before_its_noun_qualifies_that_noun() -> None:
    # "the closest chair to the monitor" is a chair (it was read as "closest to the chair")
    scene = _scene(KITCHEN)
    assert ask(scene, "the closest chair to the monitor") == (6,)
    assert ask(scene, "the nearest stool to the bookshelf") == (4,)
    # measured from where the observer stands when no "to" follows
    assert ask(scene, "standing at the bookshelf, the closest stool") == (4,)
    assert ask(scene, "If you are standing at the stove, it is the closest stool.") == (3,)


def test_a_relation_that_selects_nothing_leaves_the_choice_to_the_phrase_s_selector() -> None:
    # pictures hang in front of the wall (no support edge); "the highest picture on the wall"
    # is the highest, not the one closest to the wall, and without a selector of its own the
    # phrase still takes the closest
    boxes: list[Box] = [
        (1, "wall", (0.0, 0.0, 1.5), (6.0, 0.1, 3.0)),
        (2, "picture", (-1.0, 0.15, 1.2), (0.5, 0.05, 0.4)),
        (3, "picture", (2.5, 0.25, 2.2), (0.5, 0.05, 0.4)),
        (4, "picture", (0.2, 0.12, 1.4), (0.5, 0.05, 0.4)),
    ]
    scene = _scene(boxes)
    answer = REASONER.answer("the highest picture on the wall", scene)
    assert answer.entity_ids == (3,)
    assert "the relation was not used" in answer.explanation
    assert ask(scene, "the picture on the wall") == (4,)


def test_top_and_bottom_before_a_noun_single_out_the_highest_and_lowest() -> None:
    boxes: list[Box] = [
        (1, "shelf", (0.0, 0.0, 1.0), (1.0, 0.4, 2.0)),
        (2, "box", (0.0, 0.0, 0.3), (0.4, 0.3, 0.3)),
        (3, "box", (0.1, 0.0, 1.1), (0.4, 0.3, 0.3)),
        (4, "box", (-0.1, 0.0, 1.8), (0.4, 0.3, 0.3)),
    ]
    scene = _scene(boxes)
    assert ask(scene, "the bottom box") == (2,)
    assert ask(scene, "pick the top box") == (4,)
    # a noun of position elsewhere stays a noun: "on top of the shelf" is a relation
    ins = REASONER.parse("the box on top of the shelf", scene)
    assert ins.target is not None and ins.target.extremes == ()


def test_a_place_in_a_pile_or_over_all_the_others_is_a_height() -> None:
    # three towels stacked on a shelf, a fourth hanging beside them at the pile's middle
    # height: "the top of the pile" names no anchor the scene has, "all the other towels"
    # no single one; both rank the towels by height
    boxes: list[Box] = [
        (1, "shelf", (0.0, 0.0, 0.5), (1.0, 0.4, 1.0)),
        (2, "towel", (0.0, 0.0, 1.05), (0.5, 0.3, 0.1)),
        (3, "towel", (0.0, 0.0, 1.15), (0.5, 0.3, 0.1)),
        (4, "towel", (0.05, 0.0, 1.25), (0.5, 0.3, 0.1)),
        (5, "towel", (2.0, 0.0, 1.15), (0.05, 0.4, 0.6)),
    ]
    scene = _scene(boxes)
    assert ask(scene, "the towel on top of the pile") == (4,)
    assert ask(scene, "the towel that's at the top of the stack") == (4,)
    assert ask(scene, "the towel above all the others") == (4,)
    assert ask(scene, "The towel under all the other towels.") == (2,)
    assert ask(scene, "the towel at the bottom of the heap") == (2,)
    assert ask(scene, "the elevated towel") == (4,)
    # under a thing the scene has is still a relation to it
    ins = REASONER.parse("the towel under the shelf", scene)
    assert ins.target is not None and ins.target.extremes == ()


@pytest.mark.parametrize(
    ("text", "kind"),
    [
        ("the thing to the left of the stove", "refer"),
        ("something to the right of the bookshelf", "refer"),
        ("the thing that is next to the stove", "refer"),
        ("something to sit on", "action"),
        ("hand me the thing to sit on next to the stove", "action"),
        ("something that I can sit on", "action"),
        ("I need a place to put my books", "action"),
    ],
)
def test_to_of_a_place_is_no_purpose(text: str, kind: str) -> None:
    # "to" before a determiner is the preposition of a place, not the mark of a purpose
    assert REASONER.parse(text, _scene(KITCHEN)).kind == kind


def test_a_universal_quantifier_asks_for_every_entity_that_qualifies() -> None:
    scene = _scene(KITCHEN)
    # both stools stand near something; "the stool near the stove" is one of them
    assert ask(scene, "the stool next to the stove") == (3,)
    assert REASONER.parse("all the stools", scene).kind == "set"
    assert ask(scene, "all the stools") == (3, 4)
    assert ask(scene, "every chair") == (6, 7)
    assert REASONER.parse("each stool next to the stove", scene).kind == "set"
    # a quantifier after the target's noun does not govern it
    assert REASONER.parse("the stool that is closest to all the chairs", scene).kind == "refer"


def test_a_demonstrative_points_at_the_phrase_described() -> None:
    # "there is a lamp on this desk" describes the desk, not the lamp
    boxes: list[Box] = [
        (1, "desk", (0.0, 0.0, 0.4), (1.2, 0.6, 0.8)),
        (2, "desk", (3.0, 0.0, 0.4), (1.2, 0.6, 0.8)),
        (3, "lamp", (3.2, 0.0, 1.0), (0.2, 0.2, 0.4)),
        (4, "chair", (0.0, 1.0, 0.45), (0.5, 0.5, 0.9)),
    ]
    scene = _scene(boxes)
    assert ask(scene, "There is a lamp on this desk.") == (2,)
    assert ask(scene, "There is no lamp on this desk.") == (1,)
    assert ask(scene, "there are chairs next to this desk") == (1,)
    # "this" on the target itself changes nothing
    assert ask(scene, "This desk has a lamp on it.") == (2,)
    # "this" before a noun said before points back at it: the target stays
    ins = REASONER.parse("facing the lamp, choose the desk that is under this lamp", scene)
    assert ins.target is not None and ins.target.categories == ("desk",)
    assert ask(scene, "facing the lamp, choose the desk that is under this lamp") == (2,)


def test_a_long_viewpoint_clause_before_a_short_main_clause() -> None:
    # the viewpoint's phrase is read from the viewpoint clause's tokens: the main clause's
    # (shorter) tokens must not be indexed with its positions (this raised IndexError)
    scene = _scene(KITCHEN)
    text = (
        "When standing in the middle of the kitchen looking at the stools, pick the one on "
        "top of it."
    )
    assert len(ask(scene, text)) == 1


def test_another_name_the_knowledge_table_gives_a_kind_names_it() -> None:
    # "wastebasket" and "garbage can" are other names of the trash can's entry; a
    # category that is itself another name of an entry ("round table" of "table") takes
    # none of that entry's names, so "the square table" is not the round one
    room = _scene([(1, "trash can", (0.0, 0.0, 0.3), (0.4, 0.4, 0.6)),
                   (2, "round table", (3.0, 0.0, 0.4), (1.0, 1.0, 0.8)),
                   (3, "table", (6.0, 0.0, 0.4), (1.2, 0.8, 0.8))])  # fmt: skip
    assert ask(room, "the wastebasket") == (1,)
    assert ask(room, "the garbage can by the round table") == (1,)
    assert ask(room, "the square table") == (3,)


def test_another_of_the_same_kind_when_the_words_leave_one() -> None:
    # both trash cans are grey, but only one is stored as grey: "the grey trash can left
    # of another grey trash can" leaves that one as its own anchor; it is the answer, not
    # nothing
    from causalsplat.objects import objects_to_scene_graph, parse_objects

    doc = {"scene_id": "cans", "objects": [
        {"id": 1, "label": "trash can", "center": [0, 0, 0.3], "size": [0.4, 0.4, 0.6],
         "attributes": {"color": "gray"}},
        {"id": 2, "label": "trash can", "center": [2, 0, 0.3], "size": [0.4, 0.4, 0.6]},
    ]}  # fmt: skip
    ctx = SceneContext(objects_to_scene_graph(parse_objects(doc)))
    for text in ("this is a gray trash can. it is to the left of another gray trash can.",
                 "the gray trash can next to another gray trash can"):  # fmt: skip
        answer = REASONER.answer(text, ctx)
        assert answer.entity_ids == (1,), answer.explanation
        assert "relation was not used" in answer.explanation


def test_the_closest_instead_never_leaves_nothing() -> None:
    # the second sentence's relation points back at the target's own kind ("to the right
    # of the curtain"): when the one curtain left is its only anchor, taking the closest
    # would leave nothing; the curtain is kept
    room = _scene([(1, "curtain", (0.0, 2.0, 1.2), (1.5, 0.1, 2.2)),
                   (2, "bed", (3.0, 0.0, 0.3), (2.0, 1.6, 0.6)),
                   (3, "dresser", (6.0, 1.5, 0.5), (1.0, 0.5, 1.0))])  # fmt: skip
    text = "a curtain is hanging behind the bed. there is a dresser to the right of the curtain."
    answer = REASONER.answer(text, room)
    assert answer.entity_ids == (1,), answer.explanation


def test_a_list_of_adjectives_stays_inside_the_viewpoint_clause(room: SceneContext) -> None:
    # "the big, brown table": the commas list adjectives; the clause runs to the table, and
    # the observer stands at the door ("stood", a past form of standing) looking at it
    for verb in ("stood", "stand", "sat"):
        ins = REASONER.parse(
            f"if you {verb} at the door looking at the big, brown table, the chair on the left",
            room,
        )
        assert ins.viewpoint is not None and ins.viewpoint.categories == ("table",)
        assert ins.observer_at is not None and ins.observer_at.categories == ("door",)
        assert ins.target is not None and ins.target.categories == ("chair",)
    # a comma after a colour that ends its phrase still ends the clause
    assert split("facing the table that is brown, the chair on the left") == (
        "facing the table that is brown ,",
        "the chair on the left",
    )


@pytest.mark.parametrize(
    "text",
    ["the chair between the other two", "the chair between the two others",
     "the chair between the others"],
)  # fmt: skip
def test_the_other_two_are_of_the_targets_kind(room: SceneContext, text: str) -> None:
    # "the other two" leaves its noun out: the other two chairs
    ins = REASONER.parse(text, room)
    assert ins.target is not None
    (between,) = ins.target.constraints
    assert between.kind == "between" and between.anchors[0].text == "ones"
    # a noun after the number, and "the other one", keep their reading
    ins = REASONER.parse("the chair next to the other two cups", room)
    assert ins.target is not None and ins.target.constraints[0].anchors[0].categories == ("cup",)
    ins = REASONER.parse("the chair closer to the door than the other one", room)
    assert "ones" not in ins.tokens


def test_can_after_a_determiner_and_adjectives_is_a_noun() -> None:
    # "can" is a modal verb ("where can I sit") unless a determiner comes before it, past
    # size and colour words: "the smaller can" is a (trash) can, the smaller one
    room = _scene([(1, "trash can", (0.0, 0.0, 0.3), (0.4, 0.4, 0.6)),
                   (2, "trash can", (3.0, 0.0, 0.2), (0.3, 0.3, 0.4)),
                   (3, "door", (3.5, 0.0, 1.0), (0.9, 0.1, 2.0)),
                   (4, "printer", (3.0, 0.8, 0.8), (0.5, 0.4, 0.3))])  # fmt: skip
    assert ask(room, "the smaller can by the door") == (2,)
    assert ask(room, "the small can") == (2,)
    # after a noun it stays a verb
    ins = REASONER.parse("the door on the right can be opened", room)
    assert ins.target is not None and ins.target.categories == ("door",)


def test_from_a_place_at_the_start_stands_there(room: SceneContext) -> None:
    ins = REASONER.parse("from the door, the chair on the left", room)
    assert ins.viewpoint is not None and ins.standing_at


def test_neither_nor_negates_both_relations() -> None:
    # three trash cans: by the toilet, by the desk, and one by neither
    room = _scene([(1, "toilet", (0.0, 0.0, 0.4), (0.5, 0.7, 0.8)),
                   (2, "desk", (5.0, 0.0, 0.4), (1.2, 0.6, 0.8)),
                   (3, "trash can", (0.6, 0.0, 0.2), (0.3, 0.3, 0.4)),
                   (4, "trash can", (5.9, 0.0, 0.2), (0.3, 0.3, 0.4)),
                   (5, "trash can", (2.5, 3.0, 0.2), (0.3, 0.3, 0.4))])  # fmt: skip
    text = "the trash can that is neither by the toilet nor by the desk"
    ins = REASONER.parse(text, room)
    assert ins.target is not None
    assert [c.negated for c in ins.target.constraints] == [True, True]
    assert ask(room, text) == (5,)
    # "not by A or B" is by neither; "by A or B" keeps its one relation
    assert ask(room, "the trash can that is not by the toilet or the desk") == (5,)
    ins = REASONER.parse("the trash can next to the toilet or the desk", room)
    assert ins.target is not None and len(ins.target.constraints) == 1


#: A hall entered through door 1 on its south side: stools two rows deep ahead of it (2
#: front left, 3 front right, 4 back left, 5 back right, as one comes in), a bookshelf
#: against the north wall and a desk with its chair east of the stools.
HALL: list[Box] = [
    (1, "door", (0.0, -3.0, 1.0), (1.0, 0.1, 2.0)),
    (2, "stool", (-1.0, 0.0, 0.35), (0.4, 0.4, 0.7)),
    (3, "stool", (1.0, 0.2, 0.35), (0.4, 0.4, 0.7)),
    (4, "stool", (-1.0, 3.0, 0.35), (0.4, 0.4, 0.7)),
    (5, "stool", (1.0, 3.4, 0.35), (0.4, 0.4, 0.7)),
    (6, "bookshelf", (0.0, 5.0, 1.0), (2.0, 0.4, 2.0)),
    (7, "desk", (4.0, 0.0, 0.4), (1.2, 0.6, 0.8)),
    (8, "chair", (4.0, 0.7, 0.45), (0.5, 0.5, 0.9)),
]


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("as you come in through the door, the stool at the back left", (4,)),
        ("as you come in through the door, the stool in the back right of the room", (5,)),
        ("as you come in through the door, the front right stool", (3,)),
        ("as you come in through the door, the stool at the front of the room", (2,)),
        ("entering through the door, the stool at the far end of the room", (5,)),
        ("entering through the door, the stool at the back", (5,)),
    ],
)
def test_back_and_front_of_the_room_are_seen_from_the_observer(
    text: str, expected: tuple[int, ...]
) -> None:
    # the farthest or nearest ahead of the observer, and of a side the one on it
    assert ask(_scene(HALL), text) == expected


def test_back_and_front_of_a_thing_are_not_the_room_s() -> None:
    hall = _scene(HALL)
    for text, kind in (
        ("the chair at the back of the desk", "behind"),
        ("the chair in front of the desk", "in_front_of"),
        ("the stool at the back wall", "near"),
    ):
        ins = REASONER.parse(text, hall)
        assert ins.target is not None and ins.target.extremes == ()
        assert [c.kind for c in ins.target.constraints] == [kind]
    # "on the back" alone is the thing's own back; "on the back left" a place
    ins = REASONER.parse("the chair with holes on the back", hall)
    assert ins.target is not None and ins.target.extremes == ()
    ins = REASONER.parse("the stool on the back left", hall)
    assert ins.target is not None and ins.target.extremes == ((Metric.FORWARD, Op.ARGMAX),)


#: Two trash cans along the west wall (1, 2), three along the east wall (3-5), a desk in
#: the north-west corner; 5 is the largest and tallest, 1 the next.
BINS: list[Box] = [
    (1, "trash can", (-3.0, -2.0, 0.4), (0.5, 0.5, 0.8)),
    (2, "trash can", (-3.0, -1.2, 0.3), (0.4, 0.4, 0.6)),
    (3, "trash can", (3.0, -2.0, 0.3), (0.4, 0.4, 0.6)),
    (4, "trash can", (3.0, 0.0, 0.3), (0.4, 0.4, 0.6)),
    (5, "trash can", (3.0, 2.0, 0.45), (0.6, 0.6, 0.9)),
    (6, "desk", (-2.5, 2.0, 0.4), (1.2, 0.6, 0.8)),
]


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("on the side with three trash cans, the one closest to the desk", (5,)),
        ("on the side with two trash cans, the largest trash can", (1,)),
        ("the trash can on the side of the room with 3 trash cans that is closest to the desk",
         (5,)),
        ("on the wall with two trash cans, the tallest one", (1,)),
        ("the largest trash can not on the side with three trash cans", (1,)),
        ("the trash can in the cluster of three that is closest to the desk", (5,)),
        ("the largest of the pair of trash cans", (1,)),
        ("the largest of the two trash cans", (1,)),
        ("out of the three trash cans, the one closest to the desk", (5,)),
    ],
)  # fmt: skip
def test_the_side_with_a_number_of_things_is_where_they_stand_together(
    text: str, expected: tuple[int, ...]
) -> None:
    assert ask(_scene(BINS), text) == expected


def test_no_side_holds_the_number_said_apart() -> None:
    # five trash cans are no side with six: the words say nothing, the rest chooses
    assert ask(_scene(BINS), "on the side with six trash cans, the one closest to the desk") == (2,)


def test_a_viewpoint_at_the_centre_gives_no_direction_of_its_own() -> None:
    # sitting at the chair in the middle of the room, the observer could look anywhere:
    # left and right are read as from the centre looking at the tables, not along the few
    # centimetres between the chair and the centre
    room = _scene([
        (1, "chair", (-0.1, 0.15, 0.45), (0.5, 0.5, 0.9)),
        (2, "table", (-2.0, 3.0, 0.4), (1.2, 0.8, 0.8)),
        (3, "table", (2.0, 3.0, 0.4), (1.2, 0.8, 0.8)),
        (4, "bookshelf", (0.0, -3.0, 1.0), (1.0, 0.4, 2.0)),
    ])  # fmt: skip
    assert ask(room, "sitting at the chair in the centre of the room, the table on the left") == (
        2,
    )
    assert ask(room, "sitting at the chair in the centre of the room, the table on the right") == (
        3,
    )


def test_a_lone_thing_stands_apart(room: SceneContext) -> None:
    for text in ("the lone chair", "the solitary chair", "the chair on its own"):
        ins = REASONER.parse(text, room)
        assert ins.target is not None and ins.target.place == "alone"


#: A window and four stools in a line away from it (2 nearest, 5 farthest).
ROW: list[Box] = [
    (1, "window", (0.0, 0.0, 1.5), (1.2, 0.1, 1.0)),
    *((k, "stool", (0.0, float(k - 1), 0.35), (0.4, 0.4, 0.7)) for k in range(2, 6)),
]


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("the last stool from the window", (5,)),
        ("the next to last stool from the window", (4,)),
        ("the penultimate stool from the window", (4,)),
        ("the second to last stool from the window", (4,)),
        ("the stool that is last but one from the window", (4,)),
        ("the third to last stool from the window", (3,)),
        ("the second stool from the window", (3,)),
        ("the stool next to the window", (2,)),
    ],
)
def test_counting_from_the_far_end(text: str, expected: tuple[int, ...]) -> None:
    assert ask(_scene(ROW), text) == expected


def test_second_to_last_from_a_side_is_second_from_the_other() -> None:
    ins = REASONER.parse("the second to last stool from the left", _scene(ROW))
    assert ins.target is not None and (ins.target.side, ins.target.ordinal) == ("left", -2)


def test_each_other_asks_for_one() -> None:
    # "two doors next to each other, the larger one": how they stand, not every one
    ins = REASONER.parse(
        "on the wall with two trash cans beside each other, it's the taller one", _scene(BINS)
    )
    assert ins.kind == "refer"
    assert REASONER.parse("each trash can by the desk", _scene(BINS)).kind == "set"


def test_a_side_and_closest_pick_the_closest_on_that_side() -> None:
    # seen from the door (looking north), stools 2 and 4 are on the left; of them, the
    # one closest to the bookshelf is 4; the closest of all is 5
    assert ask(_scene(HALL), "entering through the door, the stool on the left that is"
               " closest to the bookshelf") == (4,)  # fmt: skip


@pytest.mark.parametrize(("word", "side"), [("righthand", "right"), ("lefthand", "left")])
def test_a_hand_side_written_as_one_word(word: str, side: str) -> None:
    ins = REASONER.parse(f"the {word} stool closest to the bookshelf", _scene(HALL))
    assert ins.target is not None and ins.target.side == side


def test_not_the_largest_is_every_other_one() -> None:
    bins = _scene(BINS)
    # of the four that are not the largest (5), the largest is 1
    assert ask(bins, "the trash can that is not the largest") == (1,)
    assert ask(bins, "the trash can that isn't the biggest one") == (1,)
    assert REASONER.parse("the largest trash can", bins).target.not_extremes == ()  # type: ignore[union-attr]


#: A long bathroom (x -2..2, y -4..4) with its walls; a mirror hangs on the east wall near
#: the south corner with a light on either side of it; a radiator on the north wall has a
#: bin in front of it and one beside it.
BATHROOM: list[Box] = [
    (1, "wall", (2.0, 0.0, 1.2), (0.1, 8.0, 2.4)),
    (2, "wall", (-2.0, 0.0, 1.2), (0.1, 8.0, 2.4)),
    (3, "wall", (0.0, 4.0, 1.2), (4.0, 0.1, 2.4)),
    (4, "wall", (0.0, -4.0, 1.2), (4.0, 0.1, 2.4)),
    (5, "mirror", (1.9, -3.0, 1.5), (0.05, 0.7, 1.0)),
    (6, "light", (1.9, -2.4, 1.6), (0.1, 0.1, 0.4)),
    (7, "light", (1.9, -3.6, 1.6), (0.1, 0.1, 0.4)),
    (8, "radiator", (-0.6, 3.85, 0.4), (1.2, 0.15, 0.6)),
    (9, "trash can", (-0.6, 3.3, 0.2), (0.3, 0.3, 0.4)),
    (10, "trash can", (0.9, 3.8, 0.2), (0.3, 0.3, 0.4)),
]


def test_things_on_a_wall_are_seen_from_the_room() -> None:
    # A mirror or a radiator has no annotated front; it faces away from its wall. Seen
    # from the room (looking east at the mirror), left is north: light 6. Before, the
    # observer stood at the scene centre, looking down the room along the wall, and
    # neither light was left of the mirror (the closest answered).
    scene = _scene(BATHROOM)
    assert scene.wall_facing(5) == (-1.0, 0.0)
    assert scene.wall_facing(8) == (0.0, -1.0)
    assert scene.wall_facing(1) is None  # a wall faces nothing
    assert ask(scene, "the light on the left side of the mirror") == (6,)
    assert ask(scene, "the light to the right of the mirror") == (7,)
    # in front of the radiator: between it and the room, not beside it along the wall
    assert ask(scene, "the trash can in front of the radiator") == (9,)


def test_on_furniture_nothing_stands_on_is_the_raised_one() -> None:
    # Neither plant is on, above or near the counter (the object table misplaces it, or
    # the plant stands on something unlabelled): what stands on furniture is raised off
    # the floor, so plant 3, not plant 2 on the floor nearer the counter.
    boxes: list[Box] = [
        (1, "counter", (0.0, 0.0, 0.45), (2.0, 0.6, 0.9)),
        (2, "plant", (3.0, 3.0, 0.3), (0.4, 0.4, 0.6)),
        (3, "plant", (-4.0, 3.5, 1.2), (0.3, 0.3, 0.5)),
        (4, "floor", (0.0, 1.0, 0.0), (10.0, 8.0, 0.05)),
    ]
    scene = _scene(boxes)
    assert ask(scene, "the plant sitting on top of the counter") == (3,)
    # on the floor (structural) stays the closest: not the highest
    assert ask(scene, "the plant on the floor") == (2,)


def test_left_of_another_of_its_kind_is_the_leftmost() -> None:
    # Three monitors in a row on a desk, seen from the room (south of them, looking
    # north): each but the rightmost is left of another; the one said is the leftmost,
    # not the one closest to the others.
    boxes: list[Box] = [
        (1, "desk", (0.0, 3.0, 0.4), (3.0, 0.8, 0.8)),
        (2, "monitor", (-1.0, 3.0, 1.0), (0.5, 0.2, 0.4)),
        (3, "monitor", (0.0, 3.0, 1.0), (0.5, 0.2, 0.4)),
        (4, "monitor", (1.0, 3.0, 1.0), (0.5, 0.2, 0.4)),
        (5, "couch", (0.0, -3.0, 0.4), (2.0, 0.9, 0.8)),
    ]
    scene = _scene(boxes)
    assert ask(scene, "this is a black monitor. it is to the left of another monitor.") == (2,)
    assert ask(scene, "the monitor to the right of the other monitors") == (4,)


def test_against_the_wall_keeps_those_against_it_for_the_rest_to_choose() -> None:
    # Three chairs stand against the north wall, one in the middle of the room further
    # left. "Against the wall" keeps the three (stored relations never relate a chair to
    # a wall: before, the relation was dropped and the middle one was the leftmost).
    boxes: list[Box] = [
        (1, "wall", (0.0, 3.0, 1.2), (6.0, 0.1, 2.4)),
        (2, "wall", (0.0, -3.0, 1.2), (6.0, 0.1, 2.4)),
        (3, "wall", (3.0, 0.0, 1.2), (0.1, 6.0, 2.4)),
        (4, "wall", (-3.0, 0.0, 1.2), (0.1, 6.0, 2.4)),
        (5, "chair", (-1.0, 2.65, 0.45), (0.5, 0.5, 0.9)),
        (6, "chair", (0.0, 2.65, 0.45), (0.5, 0.5, 0.9)),
        (7, "chair", (1.0, 2.65, 0.45), (0.5, 0.5, 0.9)),
        (8, "chair", (-2.0, 0.5, 0.45), (0.5, 0.5, 0.9)),
    ]
    scene = _scene(boxes)
    assert ask(scene, "the chair against the wall, the one on the left") == (5,)
    assert ask(scene, "it is the leftmost chair on the wall") == (5,)
