"""The wire format of the structured graph-query language (DESIGN §6), as pydantic models.

A program is a flat list of steps in single assignment: step ``i`` may only read the
results of steps ``0..i-1`` (its ``inputs``). Every step yields a set of entity ids,
except ``count`` (a number) and ``exists`` (a bool), whose results are never inputs.

>>> q = GraphQuery.parse({
...     "query_type": "spatial",
...     "steps": [
...         {"op": "scene"},
...         {"op": "filter_category", "inputs": [0], "value": "sink"},
...         {"op": "filter_category", "inputs": [0], "value": "towel"},
...         {"op": "relate", "inputs": [2, 1], "relation": "near"},
...     ],
...     "answer_step": 3,
... })
>>> print(q.to_text())
query spatial
v0 = scene()
v1 = filter_category(v0, "sink")
v2 = filter_category(v0, "towel")
v3 = relate(v2, v1, near)
return v3

Every way in (:meth:`GraphQuery.parse`, ``GraphQuery(...)``, ``model_validate``,
``model_validate_json``, :meth:`GraphQuery.from_text`) raises only
:class:`~queries.errors.QueryValidationError` on bad input, naming the step and the field.
The per-op rules are in :data:`OP_SPECS` and :mod:`queries._validate`.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from contextvars import ContextVar
from dataclasses import dataclass
from enum import StrEnum
from typing import Annotated, Any, Self, TypeVar

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ValidationError,
    field_validator,
    model_validator,
)

from graph_store.types import RelationType
from queries.errors import QueryValidationError

#: Least horizontal distance between a viewpoint's eye and target (scene units): closer,
#: there is no direction to look in.
MIN_VIEW_DISTANCE = 1e-6
#: Most steps a program may have (also the schema's ``maxItems`` on ``steps``).
MAX_STEPS = 64
#: Most inputs of one ``union`` / ``intersect`` / ``coalesce`` step.
MAX_SET_INPUTS = 8
#: Largest ``k`` (ranked ops keep at most this many entities).
MAX_K = 100_000
#: Longest ``value`` string, in characters.
MAX_VALUE_LENGTH = 512


class QueryType(StrEnum):
    """The reasoning level of a program (stage 1 of the method)."""

    INTRINSIC = "intrinsic"
    SPATIAL = "spatial"
    COMMONSENSE = "commonsense"
    AFFORDANCE = "affordance"
    COUNTERFACTUAL = "counterfactual"


class Op(StrEnum):
    """The operations of the language; see :data:`OP_SPECS` for their signatures."""

    SCENE = "scene"
    FILTER_CATEGORY = "filter_category"
    FILTER_ATTRIBUTE = "filter_attribute"
    FILTER_AFFORDANCE = "filter_affordance"
    MATCH_TEXT = "match_text"
    RELATE = "relate"
    RELATE_BETWEEN = "relate_between"
    ARGMIN = "argmin"
    ARGMAX = "argmax"
    MIDDLE = "middle"
    UNION = "union"
    INTERSECT = "intersect"
    DIFFERENCE = "difference"
    COALESCE = "coalesce"
    SUPPORT_CLOSURE = "support_closure"
    FALL_IF_REMOVED = "fall_if_removed"
    COUNT = "count"
    EXISTS = "exists"


class Metric(StrEnum):
    """What ``argmin`` / ``argmax`` / ``middle`` rank by (all in scene units, world frame).

    ``distance``: centroid distance to the nearest *other* member of the second input
    (without one: to the scene centre); ``horizontal_distance``: the same in the ``x``-``y``
    plane (heights ignored: "the picture above the bed" is the one most directly over
    it); ``box_distance``: centroid distance to the nearest point of a member's bounding box
    (0 inside it), for references that are surfaces more than points ("the chair against
    the wall": a wall's centroid is metres from most of it); ``box_centroid_distance``:
    ``box_distance``, members whose boxes are equally near (a centroid inside two boxes, or
    inside one) told apart by ``distance`` (the value is the box distance's square plus
    :data:`~queries.semantics.CENTROID_TIE_WEIGHT` times the centroid distance's: "the
    chair closest to the bookshelf" is the one against it, however deep the bookshelf);
    ``end_distance`` /
    ``corner_distance``: horizontal centroid distance to the middle of the nearest end (one
    of the two shorter edges) / to the nearest corner of a member's bounding-box footprint
    ("the chair at the end of the table", "the stool at the corner of the counter");
    ``z`` / ``x`` / ``y``:
    centroid coordinate;
    ``height``: vertical bounding-box extent; ``length``: the longer horizontal side of
    the bounding box ("the longest table", "the narrow window"); ``volume``: bounding-box
    volume;
    ``rightward``: how far to the right of the step's ``viewpoint`` (the observer at ``eye``
    looking at ``target``) the centroid lies, horizontally, so ``argmax`` is the rightmost,
    ``argmin`` the leftmost and ``middle`` the one in the middle as the observer sees them
    (needs ``viewpoint``);
    ``forward``: how far ahead of the observer, along the line of sight, so ``argmin`` is
    the nearest ahead and ``argmax`` the farthest ("across the room from the door": the
    observer at the door, looking into the room; needs ``viewpoint``);
    ``segment_distance``: horizontal centroid distance to the nearest segment joining a
    member of the second input to a member of the third (two distinct members, neither the
    entity itself), so of the entities between a desk and a door ``argmin`` is the one most
    squarely between them (needs both inputs; see :func:`~queries.semantics.segment_distance`).
    """

    DISTANCE = "distance"
    HORIZONTAL_DISTANCE = "horizontal_distance"
    BOX_DISTANCE = "box_distance"
    BOX_CENTROID_DISTANCE = "box_centroid_distance"
    END_DISTANCE = "end_distance"
    CORNER_DISTANCE = "corner_distance"
    Z = "z"
    HEIGHT = "height"
    LENGTH = "length"
    VOLUME = "volume"
    X = "x"
    Y = "y"
    RIGHTWARD = "rightward"
    FORWARD = "forward"
    SEGMENT_DISTANCE = "segment_distance"

    @property
    def is_seen_from(self) -> bool:
        """Ranks as an observer sees the entities: needs the step's ``viewpoint``."""
        return self in (Metric.RIGHTWARD, Metric.FORWARD)

    @property
    def is_segment(self) -> bool:
        """Ranks by distance to segments between two reference sets: needs three inputs."""
        return self is Metric.SEGMENT_DISTANCE

    @property
    def is_distance(self) -> bool:
        """Ranks by distance to a reference set (or the scene centre), not a value per entity."""
        return self.uses_box or self in (Metric.DISTANCE, Metric.HORIZONTAL_DISTANCE)

    @property
    def uses_box(self) -> bool:
        """Measures to a reference member's bounding box, not to its centroid."""
        return self in (
            Metric.BOX_DISTANCE,
            Metric.BOX_CENTROID_DISTANCE,
            Metric.END_DISTANCE,
            Metric.CORNER_DISTANCE,
        )


@dataclass(frozen=True, slots=True)
class OpSpec:
    """The signature of one op.

    Attributes:
        min_inputs / max_inputs: how many input steps it takes.
        required: fields that must be set.
        optional: fields that may be set (every other field must be absent or null).
        result: ``"set"`` (sorted entity ids), ``"count"`` (int) or ``"bool"``.
        topological: whether it follows relations (not allowed in ``intrinsic`` programs).
        signature: how it reads, for error messages and prompts.
    """

    min_inputs: int
    max_inputs: int
    required: tuple[str, ...] = ()
    optional: tuple[str, ...] = ()
    result: str = "set"
    topological: bool = False
    signature: str = ""


OP_SPECS: dict[Op, OpSpec] = {
    Op.SCENE: OpSpec(0, 0, signature="scene(): every entity of the scene"),
    Op.FILTER_CATEGORY: OpSpec(
        1, 1, ("value",), signature="filter_category(S, value): members of category value"
    ),
    Op.FILTER_ATTRIBUTE: OpSpec(
        1, 1, ("value",), signature='filter_attribute(S, "key=value"): members with that attribute'
    ),
    Op.FILTER_AFFORDANCE: OpSpec(
        1, 1, ("value",), signature="filter_affordance(S, value): members affording value"
    ),
    Op.MATCH_TEXT: OpSpec(
        1, 1, ("value",), ("k",), signature="match_text(S, text, k=1): the k best text matches"
    ),
    Op.RELATE: OpSpec(
        2,
        2,
        ("relation",),
        ("viewpoint",),
        topological=True,
        signature="relate(S, A, relation): members of S in that relation to some member of A",
    ),
    Op.RELATE_BETWEEN: OpSpec(
        3,
        3,
        topological=True,
        signature="relate_between(S, A, B): members of S between some a in A and b in B",
    ),
    Op.ARGMIN: OpSpec(
        1,
        3,
        ("metric",),
        ("k", "viewpoint"),
        signature="argmin(S, [A, [B]], metric, k=1): the k smallest",
    ),
    Op.ARGMAX: OpSpec(
        1,
        3,
        ("metric",),
        ("k", "viewpoint"),
        signature="argmax(S, [A, [B]], metric, k=1): the k largest",
    ),
    Op.MIDDLE: OpSpec(
        1,
        3,
        ("metric",),
        ("viewpoint",),
        signature="middle(S, [A, [B]], metric): the one in the middle by metric (two of an even"
        " count)",
    ),
    Op.UNION: OpSpec(2, MAX_SET_INPUTS, signature="union(S1, S2, ...)"),
    Op.INTERSECT: OpSpec(2, MAX_SET_INPUTS, signature="intersect(S1, S2, ...)"),
    Op.DIFFERENCE: OpSpec(2, 2, signature="difference(S, A): members of S not in A"),
    Op.COALESCE: OpSpec(
        2,
        MAX_SET_INPUTS,
        signature="coalesce(S1, S2, ...): the first of its inputs that is non-empty",
    ),
    Op.SUPPORT_CLOSURE: OpSpec(
        1, 1, topological=True, signature="support_closure(S): all that rests on S, transitively"
    ),
    Op.FALL_IF_REMOVED: OpSpec(
        1, 1, topological=True, signature="fall_if_removed(S): what falls when S is removed"
    ),
    Op.COUNT: OpSpec(1, 1, result="count", signature="count(S): the number of members"),
    Op.EXISTS: OpSpec(1, 1, result="bool", signature="exists(S): whether S is non-empty"),
}

#: The optional fields of a step, in wire order.
STEP_FIELDS: tuple[str, ...] = ("value", "relation", "metric", "k", "viewpoint")

_Int = Annotated[int, Field(strict=True)]
_Coord = Annotated[float, Field(strict=True, allow_inf_nan=False)]
_Xyz = Annotated[tuple[_Coord, _Coord, _Coord], Field()]


_VALIDATING: ContextVar[bool] = ContextVar("queries_validating", default=False)
_T = TypeVar("_T")


def _typed_errors(call: Callable[[], _T]) -> _T:
    """Run a validation; at the outermost level turn pydantic's error into ours.

    Nested models are validated through their ``__init__`` too, where pydantic's own error
    must pass through unchanged so it is reported with its full location (step index).
    """
    if _VALIDATING.get():
        return call()
    token = _VALIDATING.set(True)
    try:
        return call()
    except ValidationError as exc:
        raise _from_pydantic(exc) from None
    finally:
        _VALIDATING.reset(token)


class _Model(BaseModel):
    """Frozen, closed models whose every validation error is a QueryValidationError."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    def __init__(self, **data: Any) -> None:
        _typed_errors(lambda: super(_Model, self).__init__(**data))

    @classmethod
    def model_validate(cls, obj: Any, **kwargs: Any) -> Self:
        return _typed_errors(lambda: super(_Model, cls).model_validate(obj, **kwargs))

    @classmethod
    def model_validate_json(cls, json_data: str | bytes | bytearray, **kwargs: Any) -> Self:
        return _typed_errors(lambda: super(_Model, cls).model_validate_json(json_data, **kwargs))

    @classmethod
    def model_validate_strings(cls, obj: Any, **kwargs: Any) -> Self:
        return _typed_errors(lambda: super(_Model, cls).model_validate_strings(obj, **kwargs))


class Viewpoint(_Model):
    """Where the observer stands for view-dependent relations (world frame, scene units).

    ``eye`` is the observer's position and ``target`` the point looked at; only their
    horizontal (x, y) components matter.
    """

    eye: _Xyz
    target: _Xyz

    @model_validator(mode="after")
    def _looks_somewhere(self) -> Self:
        dx, dy = self.target[0] - self.eye[0], self.target[1] - self.eye[1]
        if not math.hypot(dx, dy) >= MIN_VIEW_DISTANCE:
            raise ValueError(
                "viewpoint: eye and target must be at least "
                f"{MIN_VIEW_DISTANCE} apart horizontally (x, y), got {math.hypot(dx, dy):.3g}"
            )
        return self


class Step(_Model):
    """One step: ``op`` applied to earlier steps' results (``inputs``) and its parameters."""

    op: Op
    inputs: tuple[Annotated[int, Field(strict=True, ge=0)], ...] = ()
    value: Annotated[str, Field(strict=True, max_length=MAX_VALUE_LENGTH)] | None = None
    relation: RelationType | None = None
    metric: Metric | None = None
    k: Annotated[int, Field(strict=True, ge=1, le=MAX_K)] | None = None
    viewpoint: Viewpoint | None = None

    @field_validator("inputs", mode="before")
    @classmethod
    def _null_inputs(cls, value: Any) -> Any:
        """``"inputs": null`` (as strict-mode replies may write it) means no inputs."""
        return () if value is None else value

    @property
    def spec(self) -> OpSpec:
        return OP_SPECS[self.op]

    @property
    def effective_k(self) -> int:
        """``k``, or 1 when it is not given."""
        return 1 if self.k is None else self.k

    def to_dict(self) -> dict[str, Any]:
        """The canonical JSON object: unset fields and empty ``inputs`` left out."""
        out: dict[str, Any] = {"op": self.op.value}
        if self.inputs:
            out["inputs"] = list(self.inputs)
        for name in STEP_FIELDS:
            value = getattr(self, name)
            if value is None:
                continue
            if isinstance(value, Viewpoint):
                out[name] = {"eye": list(value.eye), "target": list(value.target)}
            elif isinstance(value, StrEnum):
                out[name] = value.value
            else:
                out[name] = value
        return out


class GraphQuery(_Model):
    """A whole program: its reasoning level, its steps and which step is the answer."""

    query_type: QueryType
    steps: tuple[Step, ...] = Field(min_length=1, max_length=MAX_STEPS)
    answer_step: _Int

    @model_validator(mode="after")
    def _check(self) -> Self:
        from queries._validate import check_program

        check_program(self)
        return self

    # -- ways in -------------------------------------------------------------------------

    @classmethod
    def parse(cls, program: GraphQuery | str | bytes | dict[str, Any]) -> GraphQuery:
        """A program from an instance, its JSON text, or a dict (JSON-shaped)."""
        if isinstance(program, GraphQuery):
            return program
        if isinstance(program, str | bytes | bytearray):
            return cls.model_validate_json(program)
        if isinstance(program, dict):
            return cls.model_validate(program)
        raise QueryValidationError(f"a program must be a JSON object, got {type(program).__name__}")

    @classmethod
    def from_text(cls, text: str) -> GraphQuery:
        """Parse the text form (see :mod:`queries.text`)."""
        from queries.text import parse_text

        return parse_text(text)

    # -- ways out ------------------------------------------------------------------------

    def to_dict(self) -> dict[str, Any]:
        """The canonical JSON object of the program."""
        return {
            "query_type": self.query_type.value,
            "steps": [s.to_dict() for s in self.steps],
            "answer_step": self.answer_step,
        }

    def to_json(self, *, indent: int | None = None) -> str:
        return json.dumps(self.to_dict(), indent=indent, ensure_ascii=False)

    def to_text(self) -> str:
        """The text form (see :mod:`queries.text`); ``from_text`` reads it back exactly."""
        from queries.text import format_text

        return format_text(self)

    @staticmethod
    def json_schema() -> dict[str, Any]:
        """The flat JSON Schema for constrained decoding (see :mod:`queries.schema`)."""
        from queries.schema import graph_query_schema

        return graph_query_schema()

    @property
    def answer(self) -> Step:
        return self.steps[self.answer_step]

    @property
    def result_kind(self) -> str:
        """``"set"``, ``"count"`` or ``"bool"``: what the answer step yields."""
        return self.answer.spec.result


def _loc_text(loc: tuple[int | str, ...]) -> str:
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out


def _from_pydantic(exc: ValidationError) -> QueryValidationError:
    """The first pydantic error as a QueryValidationError naming the step and the field."""
    errors = exc.errors(include_url=False, include_input=False)
    first = errors[0]
    loc = tuple(first["loc"])
    step: int | None = None
    if len(loc) >= 2 and loc[0] == "steps" and isinstance(loc[1], int):
        step, loc = loc[1], loc[2:]
    message = str(first["msg"])
    if first["type"] == "missing":
        message = "is required"
    elif first["type"] == "extra_forbidden":
        message = "is not a field of a step" if step is not None else "is not a field"
    elif first["type"] == "model_type" and not loc:
        message = "a program must be a JSON object"
    if len(errors) > 1:
        message += f" (and {len(errors) - 1} more problem{'s' if len(errors) > 2 else ''})"
    return QueryValidationError(message, step=step, field=_loc_text(loc) or None)
