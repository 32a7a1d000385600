"""Planning never runs the program it builds: a sentence's program runs once, and what to
do when a relation selects nothing is in the program (``coalesce``), so every executor
answers it alike."""

from __future__ import annotations

import pytest

from causalsplat.reason import SceneContext
from causalsplat.reason._builder import Note, ProgramBuilder
from causalsplat.reason.offline import OfflineReasoner
from graph_store import SceneGraph
from queries import Executor, GraphQuery, Op, QueryResult, make_executor
from queries.model import MAX_STEPS

LEXICAL = OfflineReasoner(embeddings=False)

#: Sentences on the conftest room that take every kind of alternative: a relaxed relation,
#: the closest instead, a relation dropped, a negation that would leave nothing, an
#: anchor's own relation fitting none, ties broken by the anchor, by colour and by size,
#: sides, the middle, levels, "across from", "far right", viewpoints, a need, a count and
#: a counterfactual.
SENTENCES = (
    "the cup on the table",
    "the cup under the couch",
    "the cup above the lamp",
    "the cup inside the lamp",
    "the chair that is not near the table",
    "the chair next to the lamp",
    "the chair near the table with a cup under it",
    "the red cup",
    "the green cup",
    "the cup on the green box",
    "the chair",
    "the leftmost chair",
    "the middle chair",
    "the upper left cup",
    "the chair across from the couch",
    "the chair to the far right of the table",
    "facing the door, the chair on the left",
    "standing at the door, the chair on the right",
    "the cup between the chairs",
    "the chair in the corner",
    "the chair that is not in the corner",
    "the second closest chair to the door",
    "the thing I can sit on next to the table",
    "how many chairs are near the table?",
    "is there a cup on the box?",
    "what falls if the table is removed?",
)


class CountingExecutor(Executor):
    """The scene's real in-memory executor, counting the programs it runs."""

    name = "memory"

    def __init__(self, inner: Executor) -> None:
        super().__init__(inner.scene_id, inner.config)
        self.inner = inner
        self.runs: list[GraphQuery] = []

    def _execute(self, program: GraphQuery) -> QueryResult:
        self.runs.append(program)
        return self.inner.run(program)


@pytest.fixture
def counting(room_graph: SceneGraph) -> tuple[SceneContext, CountingExecutor]:
    executor = CountingExecutor(make_executor(room_graph, "room", executor="memory"))
    return SceneContext(room_graph, executor=executor), executor


@pytest.mark.parametrize("text", SENTENCES)
def test_a_sentence_runs_one_program_once(
    counting: tuple[SceneContext, CountingExecutor], text: str
) -> None:
    ctx, executor = counting
    answer = LEXICAL.answer(text, ctx)
    assert len(executor.runs) == 1, text
    assert executor.runs[0] == answer.program


def test_the_builder_cannot_run_anything(room: SceneContext) -> None:
    # the planner's only view of results is what the program says (no value / size / run)
    builder = ProgramBuilder(room)
    for name in ("value", "size", "run"):
        assert not hasattr(builder, name), name


@pytest.mark.parametrize("executor", ["networkx", "sql", "sparql"])
@pytest.mark.parametrize("text", SENTENCES)
def test_every_executor_answers_the_reasoners_programs_alike(
    room_graph: SceneGraph, room: SceneContext, executor: str, text: str
) -> None:
    answer = LEXICAL.answer(text, room)
    other = make_executor(room_graph, "room", executor=executor).run(answer.program)
    assert other.answer == room.run(answer.program).answer, text


def test_relaxed_relations_are_coalesce_steps_with_their_notes(room: SceneContext) -> None:
    # no cup is in the lamp, nor near it: the program holds the relaxations in order;
    # only the note of the one taken is in the explanation
    answer = LEXICAL.answer("the cup inside the lamp", room)
    ops = [s.op for s in answer.program.steps]
    assert Op.COALESCE in ops
    assert "took the closest instead" in answer.explanation
    assert "read as 'near'" not in answer.explanation
    # something is on the table: no relaxation is explained
    answer = LEXICAL.answer("the cup on the table", room)
    assert answer.entity_ids == (2,)
    assert "instead" not in answer.explanation


def test_coalesce_of_many_alternatives_nests_and_keeps_each_note(room: SceneContext) -> None:
    b = ProgramBuilder(room)
    categories = ["unicorn", "dragon", "griffin", "sphinx", "kraken", "yeti", "roc", "hydra",
                  "chimera", "lamp"]  # fmt: skip
    steps = [b.add(Op.FILTER_CATEGORY, 0, value=c) for c in categories]
    out = b.coalesce(*((s, f"took {c}") for s, c in zip(steps, categories, strict=True)))
    program, notes = b.program(out, "intrinsic")
    assert sum(s.op is Op.COALESCE for s in program.steps) == 2  # 7 + a nested 3
    result = room.run(program)
    assert result.answer == (9,)
    held = [n.render(result.steps) for n in notes if n.holds(result.steps, program)]
    assert held == ["took lamp"]


def test_a_coalesce_nobody_else_reads_is_spliced_into_the_next(room: SceneContext) -> None:
    b = ProgramBuilder(room)
    a, c, d = (b.add(Op.FILTER_CATEGORY, 0, value=v) for v in ("unicorn", "lamp", "chair"))
    inner = b.coalesce((a, None), (c, "the lamp"))
    out = b.coalesce((inner, None), (d, "a chair"))
    assert b.steps[out]["inputs"] == [a, c, d]
    program, notes = b.program(out, "intrinsic")
    result = room.run(program)
    assert [n.render(result.steps) for n in notes if n.holds(result.steps, program)] == ["the lamp"]


def test_a_note_on_several_says_how_many(room: SceneContext) -> None:
    b = ProgramBuilder(room)
    chairs = b.add(Op.FILTER_CATEGORY, 0, value="chair")
    lamps = b.add(Op.FILTER_CATEGORY, 0, value="lamp")
    b.note("{n} chairs", more=chairs)
    b.note("{n} lamps", more=lamps)
    program, notes = b.program(b.add(Op.UNION, chairs, lamps), "intrinsic")
    result = room.run(program)
    assert [n.render(result.steps) for n in notes if n.holds(result.steps, program)] == ["3 chairs"]
    assert Note("x", more=None).holds(result.steps, program)


def test_more_relations_than_a_program_holds_keep_the_first(room: SceneContext) -> None:
    # every relation brings its alternatives: past MAX_STEPS the last relations are left
    # out (planned again, never run), and the explanation says so; never an error
    places = ["near the table", "left of the door", "behind the couch", "next to the box",
              "under the chair", "above the floor", "beside the couch", "close to the lamp",
              "on the table", "under the lamp", "inside the box", "above the couch",
              "below the door", "under the couch", "above the chair", "inside the table",
              "left of the lamp", "on the box", "under the table", "near the door",
              "right of the couch", "in front of the lamp", "behind the chair"]  # fmt: skip
    answer = LEXICAL.answer("the cup " + ", ".join(places), room)
    assert len(answer.entity_ids) == 1
    assert len(answer.program.steps) <= MAX_STEPS
    assert f"of its {len(places)} relations were not used" in answer.explanation
