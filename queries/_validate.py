"""The rules a structurally well-typed program must also follow (run after pydantic).

Per step ``i``: its number of inputs fits its op; every input is an earlier step whose
result is a set (``count`` / ``exists`` results are never inputs); the fields its op
requires are set and every other field is absent or null; ``viewpoint`` only with a
view-dependent relation; a second ``argmin`` / ``argmax`` / ``middle`` input only with
a distance metric, a third only (and always) with ``segment_distance``; ``value`` strings
are usable (see :func:`check_value`). Program level: ``answer_step`` names a step; an
``intrinsic`` program has no topological step (``relate``, ``relate_between``,
``support_closure``, ``fall_if_removed``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from queries.errors import QueryValidationError
from queries.semantics import normalise_text, split_attribute

if TYPE_CHECKING:
    from queries.model import GraphQuery, Step


def check_program(program: GraphQuery) -> None:
    """Raise :class:`QueryValidationError` for the first rule ``program`` breaks."""
    from queries.model import QueryType

    steps = program.steps
    for i, step in enumerate(steps):
        _check_inputs(i, step, steps)
        _check_fields(i, step)
        if program.query_type is QueryType.INTRINSIC and step.spec.topological:
            raise QueryValidationError(
                f"{step.op.value!r} follows relations, which an 'intrinsic' program may not"
                " do; use query_type 'spatial' (or another non-intrinsic type)",
                step=i,
                field="op",
            )
    if not 0 <= program.answer_step < len(steps):
        raise QueryValidationError(
            f"{program.answer_step} is not a step index (the program has steps 0.."
            f"{len(steps) - 1})",
            field="answer_step",
        )


def _check_inputs(i: int, step: Step, steps: tuple[Step, ...]) -> None:
    spec = step.spec
    n = len(step.inputs)
    if not spec.min_inputs <= n <= spec.max_inputs:
        want = (
            str(spec.min_inputs)
            if spec.min_inputs == spec.max_inputs
            else f"{spec.min_inputs} to {spec.max_inputs}"
        )
        raise QueryValidationError(
            f"{step.op.value} takes {want} input(s), got {n} ({spec.signature})",
            step=i,
            field="inputs",
        )
    for pos, j in enumerate(step.inputs):
        if j >= i:
            raise QueryValidationError(
                f"refers to step {j}, but a step may only use earlier steps (0..{i - 1})"
                if i
                else f"refers to step {j}, but step 0 has no earlier steps",
                step=i,
                field=f"inputs[{pos}]",
            )
        kind = steps[j].spec.result
        if kind != "set":
            raise QueryValidationError(
                f"step {j} ({steps[j].op.value}) yields a {'number' if kind == 'count' else kind},"
                " not a set of entities, so it cannot be an input",
                step=i,
                field=f"inputs[{pos}]",
            )
    ranks = step.op.value in ("argmin", "argmax", "middle")
    if ranks and step.metric is not None and step.metric.is_segment and n != 3:
        raise QueryValidationError(
            f"{step.metric.value!r} measures to segments between two reference sets:"
            f" {step.op.value} takes 3 inputs (S, A, B) with it, got {n}",
            step=i,
            field="inputs",
        )
    if ranks and n == 3 and step.metric is not None and not step.metric.is_segment:
        raise QueryValidationError(
            "a third input (the far ends) is only used with metric 'segment_distance', not"
            f" {step.metric.value!r}",
            step=i,
            field="inputs",
        )
    if n == 2 and ranks and step.metric is not None and not step.metric.is_distance:
        raise QueryValidationError(
            "a second input (the reference set) is only used with a distance metric ("
            + ", ".join(repr(m.value) for m in type(step.metric) if m.is_distance)
            + f"), not {step.metric.value!r}",
            step=i,
            field="inputs",
        )


def _check_fields(i: int, step: Step) -> None:
    from queries.model import STEP_FIELDS

    spec = step.spec
    allowed = set(spec.required) | set(spec.optional)
    for name in spec.required:
        if getattr(step, name) is None:
            raise QueryValidationError(
                f"is required by {step.op.value} ({spec.signature})", step=i, field=name
            )
    for name in STEP_FIELDS:
        if name not in allowed and getattr(step, name) is not None:
            raise QueryValidationError(
                f"is not used by {step.op.value}; leave it out ({spec.signature})",
                step=i,
                field=name,
            )
    seen_from = step.metric is not None and step.metric.is_seen_from
    if step.viewpoint is not None and not (
        seen_from or (step.relation is not None and step.relation.is_view_dependent)
    ):
        raise QueryValidationError(
            "is only used with the view-dependent relations left_of, right_of, in_front_of"
            " and behind, and with metrics 'rightward' and 'forward'",
            step=i,
            field="viewpoint",
        )
    if seen_from and step.viewpoint is None:
        assert step.metric is not None
        raise QueryValidationError(
            f"metric {step.metric.value!r} needs a viewpoint (the observer's eye and target)",
            step=i,
            field="viewpoint",
        )
    if step.value is not None:
        check_value(i, step.op.value, step.value)


def check_value(i: int, op: str, value: str) -> None:
    """A ``value`` string: usable text, and ``key=value`` for ``filter_attribute``."""
    if "\x00" in value:
        raise QueryValidationError("contains a NUL character", step=i, field="value")
    try:
        value.encode("utf-8")
    except UnicodeEncodeError:
        raise QueryValidationError(
            f"{value!r} is not valid Unicode (lone surrogate)", step=i, field="value"
        ) from None
    if not normalise_text(value):
        raise QueryValidationError(f"{value!r} is empty", step=i, field="value")
    if op == "filter_attribute":
        parts = split_attribute(value)
        if parts is None:
            raise QueryValidationError(
                f"{value!r} must be 'key=value' with a non-empty key and value (e.g. 'color=red')",
                step=i,
                field="value",
            )
