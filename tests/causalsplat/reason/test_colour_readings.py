"""A colour word and relations read as said first, then the relations with the colour as
a ranking (decide._colour_or_relations): scans measure colours dimly and unevenly, so the
one pillow of the room nearest to "brown" is not "the brown pillow on the couch" when it
lies elsewhere."""

from __future__ import annotations

from typing import Any

import pytest

from causalsplat.objects import objects_to_scene_graph, parse_objects
from causalsplat.reason import SceneContext
from causalsplat.reason.offline import OfflineReasoner
from queries import make_executor
from tests.causalsplat.reason.test_planned_once import CountingExecutor

LEXICAL = OfflineReasoner(embeddings=False)


def _box(i: int, label: str, centre: list[float], size: list[float], rgb: tuple[int, ...]) -> Any:
    return {"id": i, "label": label, "center": centre, "size": size, "rgb": list(rgb)}


def _living_room(
    on_couch: tuple[tuple[int, ...], tuple[int, ...]] = ((110, 100, 80), (200, 200, 210)),
    on_floor: tuple[int, ...] = (140, 90, 50),
) -> SceneContext:
    """A couch with two pillows on it (default a tan and a white one); a third pillow
    (default mid-brown) on the floor 4 m away."""
    doc = {"scene_id": "living", "objects": [
        _box(1, "couch", [0, 0, 0.225], [2.0, 0.9, 0.45], (60, 60, 70)),
        _box(2, "pillow", [-0.5, 0, 0.55], [0.4, 0.4, 0.2], on_couch[0]),
        _box(3, "pillow", [0.5, 0, 0.55], [0.4, 0.4, 0.2], on_couch[1]),
        _box(4, "pillow", [4, 0, 0.1], [0.4, 0.4, 0.2], on_floor),
        _box(5, "floor", [1.5, 0, -0.01], [8, 4, 0.02], (120, 120, 120)),
    ]}  # fmt: skip
    return SceneContext(objects_to_scene_graph(parse_objects(doc)))


def test_the_colour_alone_picks_the_nearest_in_colour() -> None:
    ctx = _living_room()
    answer = LEXICAL.answer("the brown pillow", ctx)
    assert answer.entity_ids == (4,) and "1 of 3 candidates by colour" in answer.explanation


def test_relations_as_said_then_the_nearest_in_colour_of_those_that_fit() -> None:
    ctx = _living_room()
    answer = LEXICAL.answer("the brown pillow on the couch", ctx)
    assert answer.entity_ids == (2,)
    assert "no brown one fits its relations as said" in answer.explanation
    # the relaxed reading of the colour alone ("nothing is on it; read as ...") was not taken
    assert "nothing is on it" not in answer.explanation
    # where the colour and the relation agree, the first reading answers
    white = LEXICAL.answer("the white pillow on the couch", ctx)
    assert white.entity_ids == (3,) and "as said" not in white.explanation


@pytest.mark.parametrize("executor", ["networkx", "memory", "sql", "sparql"])
def test_the_program_holds_every_reading(executor: str) -> None:
    # one program: the colour filter, the relation as said on the pillows, and their
    # colour ranking, joined by coalesce; any executor answers it the same
    ctx = _living_room()
    answer = LEXICAL.answer("the brown pillow on the couch", ctx)
    ops = [s.op.value for s in answer.program.steps]
    assert ops.count("coalesce") >= 2 and ops.count("filter_attribute") >= 2
    result = make_executor(ctx.graph, "living", executor=executor).run(answer.program)
    assert tuple(result.answer) == (2,)


def test_the_ranking_keeps_only_colours_the_word_may_name() -> None:
    # the couch's pillows are blue, the floor's red: "the red pillow on the couch" is
    # neither blue one (each farther from red than a scan's colour ever is from its word),
    # so the colour's own reading stands, its relation relaxed as before
    ctx = _living_room(on_couch=((40, 60, 160), (30, 50, 140)), on_floor=(190, 40, 40))
    answer = LEXICAL.answer("the red pillow on the couch", ctx)
    assert answer.entity_ids == (4,) and "as said" not in answer.explanation
    assert "nothing is on it" in answer.explanation


def test_a_colour_the_scene_contradicts_still_answers_nothing() -> None:
    ctx = _living_room(on_couch=((40, 60, 160), (30, 50, 140)), on_floor=(35, 55, 150))
    answer = LEXICAL.answer("the yellow pillow on the couch", ctx)
    assert answer.entity_ids == () and answer.nothing_fits


def test_the_readings_are_one_program_run_once() -> None:
    graph = _living_room().graph
    counting = CountingExecutor(make_executor(graph, "living", executor="memory"))
    answer = LEXICAL.answer("the brown pillow on the couch", SceneContext(graph, executor=counting))
    assert answer.entity_ids == (2,)
    assert len(counting.runs) == 1 and counting.runs[0] == answer.program
