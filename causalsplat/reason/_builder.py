"""Growing a program step by step.

The planner appends steps (single assignment, as the language requires). What to do when
a relation selects nothing is written into the program (``coalesce``: the first of its
alternatives that selects anything), so the program is complete before it runs; the notes
that explain a choice are kept with the condition under which they hold (a ``coalesce``
took that alternative, a step kept more than one), and :meth:`Note.holds` reads them off
the executed program's steps. :meth:`ProgramBuilder.program` keeps only the steps the
answer depends on, renumbered.

Nothing here runs a program: the builder reads the scene's entities (through its
context), never its executor.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, replace
from typing import Any

from causalsplat.reason.context import SceneContext
from graph_store import RelationType
from queries import GraphQuery, Metric, Op
from queries.model import MAX_SET_INPUTS, MAX_STEPS

SCENE = 0

#: Ops whose result is a subset of their first input.
_KEEPS_FIRST = frozenset({
    Op.FILTER_CATEGORY, Op.FILTER_ATTRIBUTE, Op.FILTER_AFFORDANCE, Op.RELATE,
    Op.RELATE_BETWEEN, Op.ARGMIN, Op.ARGMAX, Op.INTERSECT, Op.DIFFERENCE,
})  # fmt: skip


class ProgramTooLong(ValueError):
    """The answer needs more steps than a program may have (``queries.model.MAX_STEPS``)."""


@dataclass(frozen=True, slots=True)
class Note:
    """One line of the explanation and when it holds: every ``(step, alternative)`` of
    ``chose`` (that ``coalesce`` step took that input, counted from 0), and step ``more``
    (when set) keeping more than one entity. ``{n}`` in ``text`` is the number ``more``
    keeps."""

    text: str
    chose: tuple[tuple[int, int], ...] = ()
    more: int | None = None

    def holds(self, steps: Sequence[Any], program: GraphQuery) -> bool:
        """Whether the note holds on an executed program's step values."""
        for index, alternative in self.chose:
            inputs = program.steps[index].inputs
            taken = next((k for k, j in enumerate(inputs) if steps[j]), None)
            if taken != alternative:
                return False
        return self.more is None or len(steps[self.more]) > 1

    def render(self, steps: Sequence[Any]) -> str:
        if self.more is None:
            return self.text
        return self.text.replace("{n}", str(len(steps[self.more])))


#: Why an alternative of :meth:`ProgramBuilder.coalesce` is taken.
Because = str | Note | Sequence[str | Note] | None


def _as_notes(because: Because) -> list[Note]:
    if because is None:
        return []
    items = [because] if isinstance(because, str | Note) else because
    return [Note(b) if isinstance(b, str) else b for b in items]


class ProgramBuilder:
    """Steps of a program under construction for one scene, and the notes explaining them."""

    def __init__(self, ctx: SceneContext) -> None:
        self.ctx = ctx
        self.steps: list[dict[str, Any]] = [{"op": "scene"}]
        self.notes: list[Note] = []
        #: the entities a candidates step selects, known without running the program: read
        #: from the scene's entities by their kinds and appearance (grounding)
        self.ids: dict[int, tuple[int, ...]] = {SCENE: tuple(sorted(ctx.by_id))}

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

    def coalesce(self, *alternatives: tuple[int, Because]) -> int:
        """The first of ``alternatives`` that selects anything: one ``coalesce`` step
        (nested past eight inputs), or the step itself when there is one alternative. Each
        alternative is a step and why it is taken (a note, notes, or ``None``); its notes
        hold only when it is. A later alternative equal to an earlier one is left out (it
        could never be taken)."""
        why: dict[int, list[Note]] = {}
        inner_of: dict[int, tuple[int, int]] = {}  # flattened alternative -> (coalesce, k)
        for step, because in alternatives:
            notes = _as_notes(because)
            if self._flattens(step) and not notes:
                # coalesce(coalesce(a, b), c) is coalesce(a, b, c)
                for k, alt in enumerate(self.steps[step]["inputs"]):
                    if alt not in why:
                        why[alt] = []
                        inner_of[alt] = (step, k)
                continue
            why.setdefault(step, notes)
        steps = list(why)
        if len(steps) == 1:
            self.notes.extend(why[steps[0]])
            return steps[0]
        if len(steps) > MAX_SET_INPUTS:
            head = steps[: MAX_SET_INPUTS - 1]
            with self.capture() as inner_notes:
                inner = self.coalesce(*((st, why[st]) for st in steps[len(head) :]))
            why[inner] = inner_notes
            steps = [*head, inner]
        out = self.add(Op.COALESCE, *steps)
        for k, step in enumerate(steps):
            self.notes.extend(replace(n, chose=((out, k), *n.chose)) for n in why[step])
        for k, step in enumerate(steps):
            if step in inner_of:
                # a flattened alternative's notes now hold when this step takes it
                taken = inner_of[step]
                self.notes.extend(
                    replace(n, chose=tuple((out, k) if c == taken else c for c in n.chose))
                    for n in list(self.notes) if taken in n.chose
                )  # fmt: skip
        return out

    def _flattens(self, index: int) -> bool:
        """Whether step ``index`` is a ``coalesce`` no other step reads (an alternative
        that is one is spliced into the ``coalesce`` that takes it)."""
        if self.steps[index]["op"] != Op.COALESCE.value:
            return False
        return not any(index in st.get("inputs", ()) for st in self.steps)

    @contextmanager
    def capture(self) -> Iterator[list[Note]]:
        """The notes written inside the block, taken out of :attr:`notes` (to be kept with
        the alternative they explain)."""
        start = len(self.notes)
        captured: list[Note] = []
        try:
            yield captured
        finally:
            captured.extend(self.notes[start:])
            del self.notes[start:]

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

    def at_most_one(self, index: int) -> bool:
        """Whether step ``index`` selects at most one entity (:meth:`at_most`)."""
        return self.at_most(index, 1)

    def at_most(self, index: int, n: int) -> bool:
        """Whether step ``index`` selects at most ``n`` entities, read from the program: a
        candidates step known to (:attr:`ids`), an ``argmin`` / ``argmax`` of at most
        ``n``, a ``coalesce`` of such, or a step that keeps members of one."""
        if index in self.ids:
            return len(self.ids[index]) <= n
        step = self.steps[index]
        op = Op(step["op"])
        if op in (Op.ARGMIN, Op.ARGMAX) and (step.get("k") or 1) <= n:
            return True
        if op is Op.COALESCE:
            return all(self.at_most(i, n) for i in step["inputs"])
        if op in _KEEPS_FIRST:
            return self.at_most(step["inputs"][0], n)
        return False

    def within(self, index: int) -> tuple[int, ...] | None:
        """The entities step ``index`` can select at most, read from the program: a
        candidates step's (:attr:`ids`), a union's or ``coalesce``'s inputs' together, the
        first input's for the steps that keep members of it; ``None`` when unknown."""
        if index in self.ids:
            return self.ids[index]
        step = self.steps[index]
        op = Op(step["op"])
        if op in (Op.UNION, Op.COALESCE):
            parts = [self.within(i) for i in step["inputs"]]
            if any(p is None for p in parts):
                return None
            return tuple(sorted({i for p in parts for i in p}))  # type: ignore[union-attr]
        if op in _KEEPS_FIRST:
            return self.within(step["inputs"][0])
        return None

    def distance_to(self, anchor: int) -> Metric:
        """The metric for "closest to / farthest from" the anchor: ``box_distance`` when the
        anchor holds only structure (a wall, the floor: its centroid may be metres from the
        part beside the object), ``distance`` (centroids) otherwise."""
        categories = self.categories(anchor)
        if categories and all(self.ctx.config.is_structural(c) for c in categories):
            return Metric.BOX_DISTANCE
        return Metric.DISTANCE

    def note(self, text: str, *, more: int | None = None) -> None:
        """Explain a choice; with ``more``, only when that step keeps several (``{n}``:
        how many)."""
        self.notes.append(Note(text, more=more))

    def program(self, answer: int, query_type: str) -> tuple[GraphQuery, tuple[Note, ...]]:
        """The program of the steps ``answer`` depends on, renumbered in order, and the
        notes, their conditions renumbered (a note whose condition is on a step the
        program leaves out is dropped); :class:`ProgramTooLong` past ``MAX_STEPS``."""
        needed: set[int] = set()
        stack = [answer]
        while stack:
            i = stack.pop()
            if i not in needed:
                needed.add(i)
                stack.extend(self.steps[i].get("inputs", []))
        if len(needed) > MAX_STEPS:
            raise ProgramTooLong(f"{len(needed)} steps; a program has at most {MAX_STEPS}")
        order = sorted(needed)
        new_index = {old: new for new, old in enumerate(order)}
        steps = []
        for old in order:
            step = dict(self.steps[old])
            if "inputs" in step:
                step["inputs"] = [new_index[j] for j in step["inputs"]]
            steps.append(step)
        program = GraphQuery.parse(
            {"query_type": query_type, "steps": steps, "answer_step": new_index[answer]}
        )
        notes: list[Note] = []
        for note in self.notes:
            used = [c for c, _ in note.chose] + ([] if note.more is None else [note.more])
            if all(i in new_index for i in used):
                chose = tuple((new_index[c], k) for c, k in note.chose)
                more = None if note.more is None else new_index[note.more]
                if (kept := Note(note.text, chose, more)) not in notes:
                    notes.append(kept)
        return program, tuple(notes)
