"""What running a program returns."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from queries.model import GraphQuery
from queries.semantics import SupportPath

#: A step's result: sorted entity ids (a set), an int (``count``) or a bool (``exists``).
StepValue = tuple[int, ...] | int | bool


@dataclass(frozen=True, slots=True)
class QueryResult:
    """The answer of a program and how it was reached; equal across executors.

    Attributes:
        scene_id: the scene the program ran on.
        program: the program.
        answer: the answer step's value: a tuple of entity ids sorted ascending, an
            ``int`` (``count``) or a ``bool`` (``exists``).
        steps: every step's value, in step order (same types as ``answer``).
        support_paths: for every ``fall_if_removed`` step, one path per fallen entity,
            sorted by (step, entity).
        executor: which executor produced it (``"networkx"``, ``"sql"``, ``"sparql"``); not
            part of equality.
    """

    scene_id: str
    program: GraphQuery
    answer: StepValue
    steps: tuple[StepValue, ...]
    support_paths: tuple[SupportPath, ...] = ()
    executor: str = field(default="", compare=False)

    @property
    def entity_ids(self) -> tuple[int, ...]:
        """The answer as entity ids; raises ``TypeError`` for a count / exists answer."""
        if not isinstance(self.answer, tuple):
            raise TypeError(f"the answer is a {type(self.answer).__name__}, not a set")
        return self.answer

    def step_size(self, index: int) -> int:
        """Number of entities of a set step, or the value of a count step (bool: 0/1)."""
        value = self.steps[index]
        return len(value) if isinstance(value, tuple) else int(value)

    def explain(self) -> str:
        """The program's text form, each step annotated with its result."""
        lines = self.program.to_text().splitlines()
        out = []
        for line in lines:
            head = line.split("=", 1)[0].strip()
            if head.startswith("v") and head[1:].isdigit():
                i = int(head[1:])
                out.append(f"{line}  # {_describe(self.steps[i])}")
            else:
                out.append(line)
        for p in self.support_paths:
            out.append(f"# v{p.step}: {p.entity} falls: " + " -> ".join(map(str, p.path)))
        return "\n".join(out)

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready document."""
        return {
            "scene_id": self.scene_id,
            "executor": self.executor,
            "program": self.program.to_dict(),
            "answer": _json_value(self.answer),
            "steps": [_json_value(v) for v in self.steps],
            "support_paths": [
                {"step": p.step, "entity": p.entity, "path": list(p.path)}
                for p in self.support_paths
            ],
        }


def _describe(value: StepValue) -> str:
    if isinstance(value, bool):
        return f"-> {str(value).lower()}"
    if isinstance(value, int):
        return f"-> {value}"
    n = len(value)
    shown = ", ".join(map(str, value[:8])) + (", ..." if n > 8 else "")
    return f"{n} entit{'y' if n == 1 else 'ies'}" + (f": {shown}" if n else "")


def _json_value(value: StepValue) -> Any:
    return list(value) if isinstance(value, tuple) else value
