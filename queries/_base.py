"""What the three executors share: the public interface and the step loop."""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from typing import Any, ClassVar

from queries.model import GraphQuery, Op, Step
from queries.result import QueryResult, StepValue
from queries.semantics import DEFAULT_CONFIG, QueryConfig, SupportPath

#: The value of a step while a program runs: a set of ids, a count or a bool.
RunValue = frozenset[int] | int | bool


class Executor(ABC):
    """Runs programs against one stored scene; subclasses are the three backends."""

    name: ClassVar[str]

    def __init__(self, scene_id: str, config: QueryConfig = DEFAULT_CONFIG) -> None:
        self.scene_id = scene_id
        self.config = config

    def run(self, program: GraphQuery | str | bytes | dict[str, Any]) -> QueryResult:
        """Run a program (a :class:`GraphQuery`, its JSON text or its dict)."""
        return self._execute(GraphQuery.parse(program))

    @abstractmethod
    def _execute(self, program: GraphQuery) -> QueryResult: ...

    def __repr__(self) -> str:
        return f"{type(self).__name__}(scene_id={self.scene_id!r})"


def step_value(value: RunValue) -> StepValue:
    """A run value in result form (sets become sorted tuples)."""
    if isinstance(value, frozenset):
        return tuple(sorted(value))
    return value


def as_set(value: RunValue) -> frozenset[int]:
    """An input value, which validation guarantees is a set."""
    if not isinstance(value, frozenset):  # pragma: no cover - excluded by validation
        raise TypeError("a count/exists result was used as a set")
    return value


Handler = Callable[[int, Step, list[frozenset[int]]], RunValue]


def run_sets(
    scene_id: str,
    program: GraphQuery,
    handlers: dict[Op, Handler],
    paths: Sequence[SupportPath],
    executor: str,
) -> QueryResult:
    """Run ``program`` step by step, each step's handler given its inputs' sets.

    ``paths`` is the list the ``fall_if_removed`` handler appends to (read at the end).
    """
    values: list[RunValue] = []
    for i, step in enumerate(program.steps):
        inputs = [as_set(values[j]) for j in step.inputs]
        values.append(handlers[step.op](i, step, inputs))
    steps = tuple(step_value(v) for v in values)
    return QueryResult(
        scene_id=scene_id,
        program=program,
        answer=steps[program.answer_step],
        steps=steps,
        support_paths=tuple(sorted(paths)),
        executor=executor,
    )


def middle(keyed: Sequence[tuple[Any, int]]) -> frozenset[int]:
    """The ids in the middle of ``(key, id)`` pairs in ascending order: the one of an odd
    count, the two of an even count (none of none)."""
    return middle_of([entity for _, entity in sorted(keyed)])


def middle_of(ordered: Sequence[int]) -> frozenset[int]:
    """The ids in the middle of ``ordered`` (ids already in rank order): the one of an odd
    count, the two of an even count (none of none)."""
    n = len(ordered)
    return frozenset(ordered[(n - 1) // 2 : n // 2 + 1])


def top_k(keyed: Sequence[tuple[Any, int]], k: int) -> frozenset[int]:
    """The ids of the first ``k`` of ``(key, id)`` pairs in ascending order."""
    return frozenset(entity for _, entity in sorted(keyed)[:k])
