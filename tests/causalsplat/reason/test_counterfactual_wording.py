"""Counterfactuals in any word order and with any verb of removal or collapse.

The room of ``conftest.py``: a table (1) holding a red cup (2) and a white box (3), a blue
cup (4) on the box. Removing the table drops 2, 3 and 4, whatever the wording.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from causalsplat.objects import objects_to_scene_graph, parse_objects, read_objects
from causalsplat.reason import SceneContext
from causalsplat.reason._conditions import lemma, removes, split_condition
from causalsplat.reason._text import tokenize
from causalsplat.reason.offline import OfflineReasoner
from causalsplat.reason.parse import parse_instruction
from queries import Op

REASONER = OfflineReasoner(embeddings=False)

#: Removal and collapse in both word orders, tenses, voices, with and without an agent.
WORDINGS = [
    "if the table is removed, what falls?",
    "what falls if the table is removed?",
    "what would fall if someone drags the table out?",
    "if someone drags the table out, what falls?",
    "what drops when the table is taken away?",
    "which things fall if the table collapses?",
    "if we haul the table away, what would fall?",
    "what falls if the table is ripped out?",
    "what falls if the table gives way?",
    "if the table gave way, what would drop to the floor?",
    "suppose the table broke, what would fall?",
    "what happens if we get rid of the table?",
    "imagine the table were pulled out: what falls?",
    "once the table is carried off, which objects fall down?",
    "what would end up on the floor if the table caved in?",
    "if the table is removed what falls",  # no comma: the question word ends the condition
    "if someone hauls the table away which things fall?",
    "what loses its support when the table goes?",  # going, said of a thing, is leaving
    "what drops without the table?",  # "without", in a question of what falls
    "what is left hanging without the table?",
    # the removal stated first, then the question, with no word of condition
    "the table gives way; what comes down with it?",
    "someone rips the table out. which things are affected?",
    "the table collapses - what goes down with it?",
    # told to remove it, then asked anything: what follows the removal
    "take away the table, what is on the floor?",
    # inverted conditions, first or last
    "what would hit the floor were the table to snap?",
    "were the table to give way, what would fall?",
    "had the table been removed, what would have fallen?",
    "should the table break, what falls?",
    # the condition says "it" of the thing the question names
    "what goes down with the table if it collapses?",
    "what falls off the table if it breaks?",
]


@pytest.mark.parametrize("text", WORDINGS)
def test_removing_the_table_in_any_wording(room: SceneContext, text: str) -> None:
    answer = REASONER.answer(text, room)
    assert answer.program.query_type.value == "counterfactual"
    assert set(answer.entity_ids) == {2, 3, 4}, answer.explanation


@pytest.mark.parametrize(
    "text",
    ["we haul the table away; what ends up on the floor?",
     "the table is hauled off, what hits the floor?",
     "take the table out - what lands on the ground?",
     "which things would land on the floor if the table were removed?",
     "what comes crashing down to the floor when the table collapses?"],
)  # fmt: skip
def test_a_question_of_what_reaches_the_floor_asks_what_falls(
    room: SceneContext, text: str
) -> None:
    # removal said first as a statement of its own (no "if"), and a question of what hits,
    # lands on or ends up on the floor: what falls
    answer = REASONER.answer(text, room)
    assert answer.program.query_type.value == "counterfactual"
    assert set(answer.entity_ids) == {2, 3, 4}, answer.explanation


@pytest.mark.parametrize(
    "text",
    ["what is on the floor?", "the box that ended up on the floor",
     "which cup is closest to the ground?"],
)  # fmt: skip
def test_the_floor_in_a_plain_question_or_description_is_no_counterfactual(
    room: SceneContext, text: str
) -> None:
    assert parse_instruction(text, REASONER.index(room)).kind != "counterfactual"


@pytest.mark.parametrize(
    "text",
    ["what falls if the box is removed?", "if the box gives way, what drops?",
     "what would fall if someone took the box away?"],
)  # fmt: skip
def test_the_removed_object_is_never_the_answer(room: SceneContext, text: str) -> None:
    assert REASONER.answer(text, room).entity_ids == (4,)


def test_everything_stacked_on_it_in_the_condition_last_order(room: SceneContext) -> None:
    answer = REASONER.answer("what is stacked on the table, if the table is removed?", room)
    assert set(answer.entity_ids) == {2, 3, 4}
    assert any(s.op is Op.SUPPORT_CLOSURE for s in answer.program.steps)


@pytest.mark.parametrize(
    "text",
    ["what is on the table if i look from the door?", "when you walk in, the chair on the left",
     "the cup that is on the table", "if you face the couch, the chair on the right",
     "take the cup out of the box",
     # a description that says something was pulled out, then a question of which
     "the box pulled out from the table. which one is it?",
     "the table is pulled out, what is on it?",
     # "were" and "had" before a noun phrase that nothing removes
     "what were the things on the table?", "which cup had the box on it?"],
)  # fmt: skip
def test_conditions_that_remove_nothing_are_not_counterfactuals(
    room: SceneContext, text: str
) -> None:
    ins = parse_instruction(text, REASONER.index(room))
    assert ins.kind != "counterfactual"


def test_lemmas_and_particles() -> None:
    assert [lemma(w) for w in ("hauled", "tore", "breaks", "toppled")] == [
        "haul", "tear", "break", "topple"]  # fmt: skip
    assert removes(("the", "shelf", "caves", "in"))
    assert not removes(("the", "shelf", "is", "in", "the", "corner"))
    assert not removes(("i", "move", "closer"))
    assert split_condition(("what", "is", "on", "the", "table")) is None


def _synth_small_0(tmp: Path) -> SceneContext:
    from causalsplat.synth import synth_scene

    synth_scene("small", 0, tmp)
    return SceneContext(objects_to_scene_graph(read_objects(tmp / "objects.json")))


def test_the_demo_room_in_both_orders(tmp_path: Path) -> None:
    ctx = _synth_small_0(tmp_path / "small0")
    reasoner = OfflineReasoner()
    first = reasoner.answer("if the table is removed, what falls?", ctx).entity_ids
    assert first  # the demo room's tables hold things
    for text in ("what falls if the table is removed?",
                 "what drops if someone drags the table out?",
                 "which things would fall if the tables collapsed?"):  # fmt: skip
        assert reasoner.answer(text, ctx).entity_ids == first, text


@pytest.mark.shared_data
def test_scene0000_in_both_orders() -> None:
    from causalsplat.bench._reasoning_referit import objects_document
    from tests.conftest import shared_data_path

    root = shared_data_path("referit3d_scannet_objects")
    ctx = SceneContext(
        objects_to_scene_graph(parse_objects(objects_document("scene0000_00", root)))
    )
    reasoner = OfflineReasoner()
    for removed in ("bed", "kitchen counter"):
        first = set(reasoner.answer(f"if the {removed} is removed, what falls?", ctx).entity_ids)
        assert first
        for text in (f"what falls if the {removed} is removed?",
                     f"what would fall if we hauled the {removed} away?",
                     f"what drops when the {removed} gives way?"):  # fmt: skip
            got = set(reasoner.answer(text, ctx).entity_ids)
            assert got == first, text


@pytest.mark.parametrize(
    "text",
    ["what falls if we haul the dresser away?", "what would fall if the desk collapsed?",
     "if the bookshelf gives way, what falls?"],
)  # fmt: skip
def test_a_kind_the_room_lacks_is_removed_from_nowhere(room: SceneContext, text: str) -> None:
    # the room's only furniture is a table: a dresser, desk or bookshelf is a kind of its
    # own that the room lacks, never a stand-in for the table
    answer = OfflineReasoner(embeddings=True).answer(text, room)
    assert answer.entity_ids == (), answer.explanation
    assert "nothing it says is removed is in the scene" in answer.explanation


@pytest.mark.parametrize(
    "text", ["the cup without a handle", "which box is without a lid?", "where do I go?"]
)
def test_without_and_go_elsewhere_remove_nothing(text: str) -> None:
    # "without" describes unless the question asks what falls; "go" removes only a thing
    # that goes at the end of its clause
    assert split_condition(tuple(text.replace("?", " ?").split())) is None


def test_a_noun_that_is_also_a_verb_of_removal_is_no_removal() -> None:
    # "trash" discards as a verb, and names a thing in "the trash can": a viewpoint clause
    # that mentions a trash can removes nothing, and removing a trash can removes it whole
    assert not removes(("you", "were", "standing", "by", "the", "trash", "can"))
    assert removes(("the", "lamp", "is", "trashed"))
    split = split_condition(tokenize("what falls if the trash can is removed?"))
    assert split is not None and split[0] == ("the", "trash", "can")
    split = split_condition(tokenize("if the table can be removed, what falls?"))
    assert split is not None and "table" in split[0]


@pytest.mark.parametrize(
    ("text", "expected"),
    [("if I move the table, what moves with it?", {2, 3, 4}),
     ("what comes along if we push the table?", {2, 3, 4}),
     ("what moves with the box if I lift it?", {4}),
     ("once someone carries the box, what goes with it?", {4})],
)  # fmt: skip
def test_what_goes_along_with_a_moved_thing_rests_on_it(
    room: SceneContext, text: str, expected: set[int]
) -> None:
    # moving a thing takes along what rests on it, transitively (support_closure); it
    # is not removed, so nothing falls
    answer = REASONER.answer(text, room)
    assert answer.program.query_type.value == "counterfactual"
    assert set(answer.entity_ids) == expected, answer.explanation
    assert "support_closure" in [s.op.value for s in answer.program.steps]
    assert "moved:" in answer.explanation


def test_moving_without_asking_what_goes_along_is_no_counterfactual(room: SceneContext) -> None:
    for text in ("if I lift the box, what is under it?", "the box I can move"):
        assert parse_instruction(text, REASONER.index(room)).kind != "counterfactual", text
