"""The JSON Schema of :class:`~queries.GraphQuery`, for constrained decoding.

The schema is flat on purpose, so that the grammar compilers of vLLM, SGLang, Ollama and
llama.cpp accept it: only ``type``, ``enum``, ``properties``, ``required``,
``additionalProperties: false``, ``items``, ``minItems`` / ``maxItems``, ``minimum`` /
``maximum``, ``minLength`` / ``maxLength`` and ``description``; no ``$ref`` / ``$defs``,
no recursion, no ``oneOf`` / ``anyOf`` / ``allOf``. Optional fields are simply not
``required`` (never ``anyOf`` with ``null``). Properties are listed in the order a model
should write them. What the schema cannot say (per-op arity, which fields an op needs,
inputs pointing backwards) is checked when the reply is validated
(:class:`~queries.errors.QueryValidationError`).

:func:`strict_schema` turns such a schema into one that OpenAI's strict structured-output
mode accepts (``"strict": true``): every object lists every property in ``required``, with
``additionalProperties: false``; an optional property becomes nullable (``anyOf`` with
``{"type": "null"}``, which the model reads as absent), except an optional array, which
becomes a required array (empty when unused: an absent ``inputs`` and an empty one mean the
same); and ``minLength`` / ``maxLength``, which strict mode does not permit on strings, become
a ``pattern`` of at most that many characters, none of them a quote, a backslash or a
control character (so a grammar compiler that copies the class, like llama.cpp's, can only
produce valid JSON). :func:`graph_query_strict_schema` is the program's strict variant; the
flat :func:`graph_query_schema` is unchanged.

:func:`graph_query_schema_by_op` says what the flat schema cannot: a step is one of a list
of per-op schemas (``anyOf``), each holding only the fields its op takes, with the op's
arity as ``minItems`` / ``maxItems`` of ``inputs``; ``relate`` is two schemas, and only the
one whose relation is seen from a viewpoint has a ``viewpoint``; ``argmin``, ``argmax`` and
``middle`` are three: the metrics seen from a viewpoint (``rightward``, ``forward``: one
input and a ``viewpoint``), ``segment_distance`` (three inputs) and the others (one or
two). Under a grammar (llama.cpp, OpenAI's strict mode, both accept ``anyOf``) a model then
cannot write a field its op does not use: a small model that fills every field it is
offered otherwise writes a viewpoint of zeros on a ``filter_category`` step.
"""

from __future__ import annotations

import copy
from typing import Any

from graph_store.types import RelationType
from queries.model import (
    MAX_K,
    MAX_SET_INPUTS,
    MAX_STEPS,
    MAX_VALUE_LENGTH,
    OP_SPECS,
    STEP_FIELDS,
    Metric,
    Op,
    QueryType,
)


def _xyz(description: str) -> dict[str, Any]:
    return {
        "type": "array",
        "items": {"type": "number"},
        "minItems": 3,
        "maxItems": 3,
        "description": description,
    }


def _build() -> dict[str, Any]:
    ops = "; ".join(spec.signature for spec in OP_SPECS.values())
    step = {
        "type": "object",
        "properties": {
            "op": {
                "type": "string",
                "enum": [op.value for op in OP_SPECS],
                "description": f"The operation. {ops}.",
            },
            "inputs": {
                "type": "array",
                "items": {"type": "integer", "minimum": 0},
                "maxItems": MAX_SET_INPUTS,
                "description": "Indices of earlier steps whose results this step reads.",
            },
            "value": {
                "type": "string",
                "minLength": 1,
                "maxLength": MAX_VALUE_LENGTH,
                "description": "Category, 'key=value' attribute, affordance or free text.",
            },
            "relation": {
                "type": "string",
                "enum": [r.value for r in RelationType],
                "description": "Relation of relate (left_of/right_of/in_front_of/behind are"
                " seen from the viewpoint).",
            },
            "metric": {
                "type": "string",
                "enum": [m.value for m in Metric],
                "description": "What argmin/argmax/middle rank by.",
            },
            "k": {
                "type": "integer",
                "minimum": 1,
                "maximum": MAX_K,
                "description": "How many entities argmin/argmax/match_text keep (default 1).",
            },
            "viewpoint": {
                "type": "object",
                "properties": {
                    "eye": _xyz("Observer position (x, y, z)."),
                    "target": _xyz("Point the observer looks at (x, y, z)."),
                },
                "required": ["eye", "target"],
                "additionalProperties": False,
                "description": "Observer for view-dependent relations (default: the scene"
                " centre looking at the anchor) and for metrics rightward and forward.",
            },
        },
        "required": ["op"],
        "additionalProperties": False,
    }
    return {
        "title": "GraphQuery",
        "description": "A structured scene-graph query: a flat list of steps, each reading"
        " only earlier steps; answer_step names the step whose result is the answer.",
        "type": "object",
        "properties": {
            "query_type": {"type": "string", "enum": [t.value for t in QueryType]},
            "steps": {"type": "array", "items": step, "minItems": 1, "maxItems": MAX_STEPS},
            "answer_step": {"type": "integer", "minimum": 0, "maximum": MAX_STEPS - 1},
        },
        "required": ["query_type", "steps", "answer_step"],
        "additionalProperties": False,
    }


_SCHEMA = _build()


def _step_schema(
    op: Op,
    relations: list[RelationType] | None = None,
    metrics: list[Metric] | None = None,
    arity: tuple[int, int] | None = None,
) -> dict[str, Any]:
    """One op's step: its own fields (the rest absent), its arity on ``inputs`` (the op's,
    or ``arity`` where the metrics take fewer or more); a ``viewpoint`` only where
    ``relations`` / ``metrics`` are seen from one (required with ``rightward`` and
    ``forward``)."""
    spec = OP_SPECS[op]
    shared = _SCHEMA["properties"]["steps"]["items"]["properties"]
    inputs = copy.deepcopy(shared["inputs"])
    inputs["minItems"], inputs["maxItems"] = arity or (spec.min_inputs, spec.max_inputs)
    props: dict[str, Any] = {
        "op": {"type": "string", "enum": [op.value], "description": spec.signature},
        "inputs": inputs,
    }
    required = ["op", "inputs", *spec.required]
    seen = metrics is not None and any(m.is_seen_from for m in metrics)
    for name in STEP_FIELDS:
        if name in spec.required or name in spec.optional:
            if name == "viewpoint":
                seen_from = any(r.is_view_dependent for r in relations) if relations else seen
                if not seen_from:
                    continue
            props[name] = copy.deepcopy(shared[name])
    if relations is not None:
        props["relation"]["enum"] = [r.value for r in relations]
    if metrics is not None:
        props["metric"]["enum"] = [m.value for m in metrics]
    if seen:
        required.append("viewpoint")
    return {
        "type": "object",
        "properties": props,
        "required": required,
        "additionalProperties": False,
    }


def _build_by_op() -> dict[str, Any]:
    variants = []
    for op in OP_SPECS:
        if op is Op.RELATE:
            split = [r for r in RelationType if not r.is_view_dependent]
            variants.append(_step_schema(op, split))
            variants.append(_step_schema(op, [r for r in RelationType if r.is_view_dependent]))
        elif op in (Op.ARGMIN, Op.ARGMAX, Op.MIDDLE):
            plain = [m for m in Metric if not (m.is_seen_from or m.is_segment)]
            variants.append(_step_schema(op, metrics=plain, arity=(1, 2)))
            seen = [m for m in Metric if m.is_seen_from]
            variants.append(_step_schema(op, metrics=seen, arity=(1, 1)))
            ends = [m for m in Metric if m.is_segment]
            variants.append(_step_schema(op, metrics=ends, arity=(3, 3)))
        else:
            variants.append(_step_schema(op))
    schema = copy.deepcopy(_SCHEMA)
    schema["properties"]["steps"]["items"] = {"anyOf": variants}
    return schema


_SCHEMA_BY_OP = _build_by_op()


def graph_query_schema() -> dict[str, Any]:
    """A fresh copy of the flat JSON Schema of a program."""
    return copy.deepcopy(_SCHEMA)


def graph_query_schema_by_op() -> dict[str, Any]:
    """A fresh copy of the program's schema with one step schema per op (module
    docstring)."""
    return copy.deepcopy(_SCHEMA_BY_OP)


def graph_query_strict_schema() -> dict[str, Any]:
    """The program's schema for OpenAI's strict mode (:func:`strict_schema`), no title."""
    schema = strict_schema(_SCHEMA)
    schema.pop("title", None)
    return schema


#: A character a bounded strict-mode string may hold (no quote, backslash or control).
STRICT_CHAR = r'[^"\\\x00-\x1f]'


def strict_string_pattern(min_length: int, max_length: int) -> str:
    """The ``pattern`` that stands for ``minLength`` / ``maxLength`` in strict mode."""
    return f"^{STRICT_CHAR}{{{min_length},{max_length}}}$"


def strict_schema(schema: dict[str, Any]) -> dict[str, Any]:
    """A new schema for OpenAI's strict mode from a flat one (module docstring).

    Only the keywords of the flat schemas are handled (objects, arrays, strings, numbers,
    ``enum``); the input is not modified.
    """
    node = copy.deepcopy(schema)
    if node.get("type") == "string" and ("minLength" in node or "maxLength" in node):
        low = node.pop("minLength", 0)
        high = node.pop("maxLength", None)
        if "enum" not in node:
            if high is None:
                raise ValueError("a strict-mode string needs a maxLength to become a pattern")
            node["pattern"] = strict_string_pattern(low, high)
    if isinstance(node.get("items"), dict):
        node["items"] = strict_schema(node["items"])
    if isinstance(node.get("anyOf"), list):
        node["anyOf"] = [strict_schema(sub) for sub in node["anyOf"]]
    if node.get("type") == "object":
        required = set(node.get("required", ()))
        properties: dict[str, Any] = {}
        for name, sub in node.get("properties", {}).items():
            sub = strict_schema(sub)
            if name not in required and sub.get("type") != "array":
                sub = _nullable(sub)
            properties[name] = sub
        node["properties"] = properties
        node["required"] = list(properties)
        node["additionalProperties"] = False
    return node


def _nullable(schema: dict[str, Any]) -> dict[str, Any]:
    out: dict[str, Any] = {"anyOf": [schema, {"type": "null"}]}
    if "description" in schema:
        out["description"] = schema.pop("description")
    return out
