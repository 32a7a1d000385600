"""Counterfactual semantics, on every backend: what falls when entities are removed.

The scene (ids in brackets; "on" = supported_by, unless said)::

    floor [0]; wall [1] on the floor; table A [2] and table B [3] on the floor;
    board [4] on A *and* B; cup [5] on the board;
    box [6] on the floor; book [7] on the box (stored as "box supports book"); pen [8] on the book;
    c1 [9] on table A and on c2 [10]; c2 [10] on c1 (a support cycle);
    "Floor " [11] (a second floor, odd case) on table B.
"""

from __future__ import annotations

from collections.abc import Callable

import pytest

from graph_store.types import Entity, Relation, SceneGraph, SceneMeta
from queries import Executor, GraphQuery
from queries.semantics import fall_rounds

MakeExecutor = Callable[[SceneGraph], Executor]

NAMES = ["floor", "wall", "table", "table", "board", "cup", "box", "book", "pen", "c1", "c2",
         "Floor "]  # fmt: skip
ON = [(1, 0), (2, 0), (3, 0), (4, 2), (4, 3), (5, 4), (6, 0), (8, 7), (9, 2), (9, 10), (10, 9),
      (11, 3)]  # fmt: skip


def scene() -> SceneGraph:
    ents = [
        Entity(i, name, (float(i), 0.0, 0.5), (i - 0.4, -0.4, 0.0), (i + 0.4, 0.4, 1.0))
        for i, name in enumerate(NAMES)
    ]
    rels = [Relation(x, y, "supported_by") for x, y in ON]
    rels.append(Relation(6, 7, "supports"))
    return SceneGraph(SceneMeta("cf"), tuple(ents), tuple(rels))


def removal(*ids: int, op: str = "fall_if_removed") -> GraphQuery:
    """``op`` applied to the union of the given entities (picked by category)."""
    steps: list[dict[str, object]] = [{"op": "scene"}]
    for i in ids:
        steps.append({"op": "filter_category", "inputs": [0], "value": NAMES[i]})
    picked = list(range(1, len(steps)))
    if len(picked) > 1:
        steps.append({"op": "union", "inputs": picked})
    steps.append({"op": op, "inputs": [len(steps) - 1]})
    return GraphQuery.parse(
        {"query_type": "counterfactual", "steps": steps, "answer_step": len(steps) - 1}
    )


@pytest.fixture
def executor(make_any: MakeExecutor) -> Executor:
    return make_any(scene())


def paths(*items: tuple[int, ...]) -> tuple[tuple[int, tuple[int, ...]], ...]:
    return tuple((p[0], p) for p in items)


def fallen(executor: Executor, program: GraphQuery) -> tuple[tuple[int, ...], tuple[object, ...]]:
    result = executor.run(program)
    step = len(program.steps) - 1
    assert all(p.step == step for p in result.support_paths)
    assert isinstance(result.answer, tuple)
    return result.answer, tuple((p.entity, p.path) for p in result.support_paths)


def test_object_on_two_supporters_stays_while_one_is_left(executor: Executor) -> None:
    # "table" selects both tables, so use the board's other supporter directly
    program = GraphQuery.parse(
        {
            "query_type": "counterfactual",
            "steps": [
                {"op": "scene"},
                {"op": "filter_category", "inputs": [0], "value": "table"},
                {"op": "argmin", "inputs": [1], "metric": "x"},  # table A only
                {"op": "fall_if_removed", "inputs": [2]},
            ],
            "answer_step": 3,
        }
    )
    result = executor.run(program)
    assert result.steps[2] == (2,)
    assert result.answer == ()  # the board still rests on table B; c1 still on c2
    assert result.support_paths == ()


def test_object_falls_when_both_supporters_are_removed(executor: Executor) -> None:
    answer, why = fallen(executor, removal(2))  # "table": both tables
    assert answer == (4, 5)
    assert why == paths((4, 2), (5, 4, 2))


def test_chain_through_a_supports_edge(executor: Executor) -> None:
    answer, why = fallen(executor, removal(6))
    assert answer == (7, 8)
    assert why == paths((7, 6), (8, 7, 6))


def test_cycle_terminates_and_holds_itself_up(executor: Executor) -> None:
    answer, _ = fallen(executor, removal(0))  # the floor
    # everything on the floor falls, except the wall (structural) and the c1/c2 cycle
    assert answer == (2, 3, 4, 5, 6, 7, 8)
    answer, why = fallen(executor, removal(9))
    assert answer == (10,)
    assert why == paths((10, 9))


def test_floor_and_walls_never_fall(executor: Executor) -> None:
    # table B alone: "Floor " [11] rests only on it but is structural; the board keeps table A
    program = GraphQuery.parse(
        {
            "query_type": "counterfactual",
            "steps": [
                {"op": "scene"},
                {"op": "filter_category", "inputs": [0], "value": "TABLE"},
                {"op": "argmax", "inputs": [1], "metric": "x"},  # table B
                {"op": "fall_if_removed", "inputs": [2]},
            ],
            "answer_step": 3,
        }
    )
    result = executor.run(program)
    assert result.steps[2] == (3,)
    assert result.answer == ()
    answer, why = fallen(executor, removal(0, 2))  # both floors and both tables
    assert 1 not in answer  # the wall rests on the floor but never falls
    assert answer == (4, 5, 6, 7, 8)
    assert (6, (6, 0)) in why


def test_support_closure_follows_both_edge_directions_and_cycles(executor: Executor) -> None:
    result = executor.run(removal(0, op="support_closure"))
    assert result.answer == (1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11)
    assert executor.run(removal(9, op="support_closure")).answer == (9, 10)
    assert executor.run(removal(5, op="support_closure")).answer == ()


def test_reference_fixpoint_function() -> None:
    supporters = {4: {2, 3}, 5: {4}, 9: {2, 10}, 10: {9}, 1: {0}}
    assert fall_rounds({2}, supporters, structural=[1]) == {}
    assert fall_rounds({2, 3}, supporters, structural=[1]) == {4: 1, 5: 2}
    assert fall_rounds({0}, supporters, structural=[1]) == {}
    assert fall_rounds({9}, supporters, structural=[1]) == {10: 1}
