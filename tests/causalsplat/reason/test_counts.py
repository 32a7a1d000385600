"""A number before the target's noun says how many are asked for ("the two stools closest
to the window"); a number that makes a group to pick from, or a sentence that picks one,
keeps one. "But the one ..." and "other than" exclude as "except" does; "what is the closest
stool to the window?" asks for a stool."""

from __future__ import annotations

import pytest

from causalsplat.objects import objects_to_scene_graph, parse_objects
from causalsplat.reason import SceneContext
from causalsplat.reason.offline import OfflineReasoner
from queries import make_executor

REASONER = OfflineReasoner(embeddings=False)

#: Four stools in a row along y, a window at the high-y end, a counter beside the row,
#: two nightstands; stool 4 is the tallest, stool 3 the next.
OBJECTS = [
    {"id": 1, "label": "stool", "center": [1.3, 0.0, 0.35], "size": [0.4, 0.4, 0.70]},
    {"id": 2, "label": "stool", "center": [1.3, 0.8, 0.35], "size": [0.4, 0.4, 0.70]},
    {"id": 3, "label": "stool", "center": [1.3, 1.6, 0.38], "size": [0.4, 0.4, 0.76]},
    {"id": 4, "label": "stool", "center": [1.3, 2.4, 0.40], "size": [0.4, 0.4, 0.80]},
    {"id": 5, "label": "window", "center": [1.3, 3.5, 1.5], "size": [1.2, 0.1, 1.0]},
    {"id": 6, "label": "kitchen counter", "center": [2.5, 0.4, 0.45], "size": [0.6, 1.2, 0.9]},
    {"id": 7, "label": "nightstand", "center": [-2.0, -2.0, 0.3], "size": [0.5, 0.4, 0.6]},
    {"id": 8, "label": "nightstand", "center": [0.0, -2.0, 0.3], "size": [0.5, 0.4, 0.6]},
]


@pytest.fixture(scope="module")
def room() -> SceneContext:
    doc = {"scene_id": "counts", "objects": OBJECTS}
    return SceneContext(objects_to_scene_graph(parse_objects(doc)))


def ask(room: SceneContext, text: str) -> tuple[int, ...]:
    return tuple(sorted(REASONER.answer(text, room).entity_ids))


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("the two stools closest to the window", (3, 4)),
        ("the 2 stools nearest the window", (3, 4)),
        ("the two closest stools to the window", (3, 4)),
        ("the three stools farthest from the window", (1, 2, 3)),
        ("two stools near the counter", (1, 2)),
        ("the two tallest stools", (3, 4)),
        ("the two nightstands", (7, 8)),
    ],
)
def test_a_number_before_the_target_says_how_many(
    room: SceneContext, text: str, expected: tuple[int, ...]
) -> None:
    assert ask(room, text) == expected


@pytest.mark.parametrize(
    "text",
    [
        "the stool closest to the window",
        "of the two nightstands, the one nearest the counter",
        "two stools are by the window, pick the one nearest the window",
        "the stool between the two nightstands and the window",
    ],
)
def test_a_group_or_a_pick_keeps_one(room: SceneContext, text: str) -> None:
    assert len(ask(room, text)) == 1


def test_the_count_is_not_the_anchors(room: SceneContext) -> None:
    # "the two stools closest to the tallest stool": one tallest stool is the anchor
    ins = REASONER.parse("the two stools closest to the tallest stool", room)
    assert ins.target is not None and ins.target.count == 2
    assert ask(room, "the two stools closest to the tallest stool") == (2, 3)


def test_the_explanation_says_how_many(room: SceneContext) -> None:
    answer = REASONER.answer("the three stools", room)
    assert len(answer.entity_ids) == 3
    assert "took the largest 3" in answer.explanation


@pytest.mark.parametrize("executor", ["networkx", "memory", "sql", "sparql"])
def test_every_executor_keeps_the_count(room: SceneContext, executor: str) -> None:
    answer = REASONER.answer("the two stools closest to the window", room)
    result = make_executor(room.graph, "counts", executor=executor).run(answer.program)
    assert sorted(result.entity_ids) == [3, 4]


@pytest.mark.parametrize(
    "text",
    [
        "every stool but the one nearest the window",
        "all the stools except the one closest to the window",
        "all stools other than the one closest to the window",
    ],
)
def test_but_and_other_than_exclude_as_except_does(room: SceneContext, text: str) -> None:
    # "but the one ..." and "other than" leave out what follows; before, "but" was read as
    # nothing and the answer was the stool the sentence excludes
    assert ask(room, text) == (1, 2, 3)


def test_but_between_two_clauses_excludes_nothing(room: SceneContext) -> None:
    ins = REASONER.parse("the stool is brown but the seat is red", room)
    assert ins.target is not None
    assert not any(c.negated for c in ins.target.constraints)


@pytest.mark.parametrize("text", ["the 1000000000000000000000 stools closest to the window",
                                  "the 99999999999 tallest stools"])  # fmt: skip
def test_a_count_beyond_the_language_s_bound_takes_every_candidate(
    room: SceneContext, text: str
) -> None:
    # a program's k is at most MAX_K; a larger count is every candidate, not an error
    assert ask(room, text) == (1, 2, 3, 4)


@pytest.mark.parametrize(
    "text",
    ["what is the closest stool to the window?", "which is the nearest stool to the window?",
     "the closest stool to the window"],
)  # fmt: skip
def test_a_wh_question_asks_for_the_closest_thing_it_names(room: SceneContext, text: str) -> None:
    # "what is the closest X to Y" asks for an X; before, the wh-question made Y the target
    # and X its anchor (the window nearest a stool)
    ins = REASONER.parse(text, room)
    assert ins.target is not None and ins.target.categories == ("stool",)
    assert ask(room, text) == (4,)
