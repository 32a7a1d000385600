"""Growing a program step by step while looking at what each step selects.

The planner appends steps (single assignment, as the language requires) and may ask what
a step evaluates to, to decide whether to relax a relation that selected nothing. Values
come from running the program prefix on the scene's executor; they are cached, since a
step never changes once added. :meth:`ProgramBuilder.program` keeps only the steps the
answer depends on, renumbered.
"""

from __future__ import annotations

from typing import Any

from causalsplat.reason.context import SceneContext
from graph_store import RelationType
from queries import GraphQuery, Metric, Op, QueryResult
from queries.model import MAX_SET_INPUTS

SCENE = 0

#: Ops whose result is a subset of their first input.
_KEEPS_FIRST = frozenset({
    Op.FILTER_CATEGORY, Op.FILTER_ATTRIBUTE, Op.FILTER_AFFORDANCE, Op.RELATE,
    Op.RELATE_BETWEEN, Op.ARGMIN, Op.ARGMAX, Op.INTERSECT, Op.DIFFERENCE,
})  # fmt: skip


class ProgramBuilder:
    """Steps of a program under construction, with their values on one scene."""

    def __init__(self, ctx: SceneContext) -> None:
        self.ctx = ctx
        self.steps: list[dict[str, Any]] = [{"op": "scene"}]
        self.notes: list[str] = []
        self._values: dict[int, tuple[int, ...] | int | bool] = {}

    def add(
        self,
        op: Op,
        *inputs: int,
        value: str | None = None,
        relation: RelationType | None = None,
        metric: Metric | None = None,
        k: int | None = None,
        viewpoint: dict[str, list[float]] | None = None,
    ) -> int:
        """Append a step; returns its index. Identical steps are shared. ``op``,
        ``relation`` and ``metric`` are the language's enums (a string is refused, so a
        misspelt name fails where it is written)."""
        if not isinstance(op, Op):
            raise TypeError(f"op must be a queries.Op, not {op!r}")
        if relation is not None and not isinstance(relation, RelationType):
            raise TypeError(f"relation must be a RelationType, not {relation!r}")
        if metric is not None and not isinstance(metric, Metric):
            raise TypeError(f"metric must be a queries.Metric, not {metric!r}")
        step: dict[str, Any] = {"op": op.value}
        if inputs:
            step["inputs"] = list(inputs)
        fields = {"value": value, "relation": relation, "metric": metric, "k": k,
                  "viewpoint": viewpoint}  # fmt: skip
        step.update({key: getattr(v, "value", v) for key, v in fields.items() if v is not None})
        for i, existing in enumerate(self.steps):
            if existing == step:
                return i
        self.steps.append(step)
        return len(self.steps) - 1

    def union(self, inputs: list[int]) -> int:
        """The union of several sets (one step per eight inputs); the set itself for one."""
        unique = list(dict.fromkeys(inputs))
        while len(unique) > 1:
            chunks = [unique[i : i + MAX_SET_INPUTS] for i in range(0, len(unique), MAX_SET_INPUTS)]
            unique = [c[0] if len(c) == 1 else self.add(Op.UNION, *sorted(c)) for c in chunks]
        return unique[0]

    def categories(self, index: int) -> frozenset[str] | None:
        """The categories step ``index`` can hold, read from the program without running it
        (``None``: any category). A category filter names one; a union joins its inputs';
        the steps that keep members of their first input keep its categories."""
        step = self.steps[index]
        op = Op(step["op"])
        if op is Op.FILTER_CATEGORY:
            return frozenset({step["value"]})
        if op is Op.UNION:
            parts = [self.categories(i) for i in step["inputs"]]
            return None if any(p is None for p in parts) else frozenset().union(*parts)
        if op in _KEEPS_FIRST:
            return self.categories(step["inputs"][0])
        return None

    def distance_to(self, anchor: int) -> Metric:
        """The metric for "closest to / farthest from" the anchor: ``box_distance`` when the
        anchor holds only structure (a wall, the floor: its centroid may be metres from the
        part beside the object), ``distance`` (centroids) otherwise."""
        categories = self.categories(anchor)
        if categories and all(self.ctx.config.is_structural(c) for c in categories):
            return Metric.BOX_DISTANCE
        return Metric.DISTANCE

    def value(self, index: int) -> tuple[int, ...]:
        """The entity ids step ``index`` selects (sorted)."""
        if index not in self._values:
            result = self.ctx.run(self._prefix(index))
            for i, v in enumerate(result.steps):
                self._values[i] = v
        value = self._values[index]
        if not isinstance(value, tuple):
            raise TypeError(f"step {index} is a {self.steps[index]['op']}, not a set")
        return value

    def size(self, index: int) -> int:
        return len(self.value(index))

    def _prefix(self, index: int) -> GraphQuery:
        return GraphQuery.parse(
            {"query_type": "spatial", "steps": self.steps[: index + 1], "answer_step": index}
        )

    def note(self, text: str) -> None:
        self.notes.append(text)

    def program(self, answer: int, query_type: str) -> GraphQuery:
        """The program of the steps ``answer`` depends on, renumbered in order."""
        needed: set[int] = set()
        stack = [answer]
        while stack:
            i = stack.pop()
            if i not in needed:
                needed.add(i)
                stack.extend(self.steps[i].get("inputs", []))
        order = sorted(needed)
        new_index = {old: new for new, old in enumerate(order)}
        steps = []
        for old in order:
            step = dict(self.steps[old])
            if "inputs" in step:
                step["inputs"] = [new_index[j] for j in step["inputs"]]
            steps.append(step)
        return GraphQuery.parse(
            {"query_type": query_type, "steps": steps, "answer_step": new_index[answer]}
        )

    def run(self, program: GraphQuery) -> QueryResult:
        return self.ctx.run(program)
