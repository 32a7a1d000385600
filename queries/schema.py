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
    Metric,
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
                "description": "What argmin/argmax rank by.",
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
                " centre looking at the anchor).",
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


def graph_query_schema() -> dict[str, Any]:
    """A fresh copy of the flat JSON Schema of a program."""
    return copy.deepcopy(_SCHEMA)
