"""The wire format: parsing, canonical JSON, validation rules and their error messages,
and the flat JSON Schema."""

from __future__ import annotations

import json
from typing import Any

import pytest
from hypothesis import given, settings

from queries import GraphQuery, Op, QueryValidationError, Step
from queries.model import MAX_STEPS, OP_SPECS
from tests.queries.query_strategies import programs

SPATIAL = {
    "query_type": "spatial",
    "steps": [
        {"op": "scene"},
        {"op": "filter_category", "inputs": [0], "value": "sink"},
        {"op": "filter_category", "inputs": [0], "value": "towel"},
        {"op": "relate", "inputs": [2, 1], "relation": "near"},
    ],
    "answer_step": 3,
}


def with_step(step: dict[str, Any], *, query_type: str = "spatial") -> dict[str, Any]:
    """SPATIAL with one more step (index 4), which is the answer."""
    doc = json.loads(json.dumps(SPATIAL))
    doc["steps"].append(step)
    doc["answer_step"] = 4
    doc["query_type"] = query_type
    return doc


def test_parse_accepts_dict_json_text_and_instances() -> None:
    q = GraphQuery.parse(SPATIAL)
    assert GraphQuery.parse(json.dumps(SPATIAL)) == q
    assert GraphQuery.parse(json.dumps(SPATIAL).encode()) == q
    assert GraphQuery.model_validate_json(json.dumps(SPATIAL)) == q
    assert GraphQuery.parse(q) is q
    assert q.steps[3] == Step(op="relate", inputs=[2, 1], relation="near")
    assert q.answer.op is Op.RELATE and q.result_kind == "set"


def test_canonical_json_round_trips_and_leaves_out_unset_fields() -> None:
    q = GraphQuery.parse(SPATIAL)
    assert q.to_dict() == SPATIAL
    assert GraphQuery.parse(q.to_json()) == q
    assert hash(q) == hash(GraphQuery.parse(SPATIAL))


@settings(max_examples=150, deadline=None)
@given(programs())
def test_canonical_json_round_trip_property(program: GraphQuery) -> None:
    assert GraphQuery.parse(program.to_json()) == program
    assert GraphQuery.parse(program.to_dict()).to_dict() == program.to_dict()


def test_nulls_count_as_absent() -> None:
    step = {"op": "count", "inputs": [3], "value": None, "relation": None, "k": None}
    q = GraphQuery.parse(with_step(step))
    assert q.steps[4] == Step(op="count", inputs=[3])


# (program, step, field, words in the message)
INVALID = [
    (with_step({"op": "relate", "inputs": [3, 5], "relation": "near"}), 4, "inputs[1]", "earlier"),
    (with_step({"op": "relate", "inputs": [3, 4], "relation": "near"}), 4, "inputs[1]", "earlier"),
    (with_step({"op": "relate", "inputs": [3], "relation": "near"}), 4, "inputs", "takes 2"),
    (with_step({"op": "union", "inputs": [1]}), 4, "inputs", "2 to 8"),
    (with_step({"op": "scene", "inputs": [0]}), 4, "inputs", "takes 0"),
    (with_step({"op": "relate", "inputs": [2, 1]}), 4, "relation", "required"),
    (with_step({"op": "filter_category", "inputs": [0]}), 4, "value", "required"),
    (with_step({"op": "argmin", "inputs": [1]}), 4, "metric", "required"),
    (with_step({"op": "count", "inputs": [1], "value": "x"}), 4, "value", "not used"),
    (with_step({"op": "union", "inputs": [1, 2], "k": 2}), 4, "k", "not used"),
    (
        with_step({"op": "filter_category", "inputs": [0], "value": "a", "metric": "z"}),
        4, "metric", "not used",
    ),
    (
        with_step({"op": "relate", "inputs": [2, 1], "relation": "near",
                   "viewpoint": {"eye": [0, 0, 0], "target": [1, 0, 0]}}),
        4, "viewpoint", "view-dependent",
    ),
    (with_step({"op": "argmax", "inputs": [1, 2], "metric": "z"}), 4, "inputs", "distance"),
    (with_step({"op": "argmax", "inputs": [1], "metric": "rightward"}), 4, "viewpoint", "needs"),
    (with_step({"op": "argmin", "inputs": [1], "metric": "forward"}), 4, "viewpoint",
     "metric 'forward' needs"),
    (
        with_step({"op": "argmin", "inputs": [1], "metric": "z",
                   "viewpoint": {"eye": [0, 0, 0], "target": [1, 0, 0]}}),
        4, "viewpoint", "metrics 'rightward' and 'forward'",
    ),
    (with_step({"op": "middle", "inputs": [1]}), 4, "metric", "required"),
    (with_step({"op": "middle", "inputs": [1], "metric": "z", "k": 1}), 4, "k", "not used"),
    (with_step({"op": "middle", "inputs": [1, 2], "metric": "x"}), 4, "inputs", "distance"),
    (with_step({"op": "middle", "inputs": [1, 2, 3], "metric": "distance"}), 4, "inputs",
     "only used with metric 'segment_distance'"),
    (with_step({"op": "argmin", "inputs": [1, 2], "metric": "segment_distance"}), 4, "inputs",
     "takes 3 inputs (S, A, B) with it, got 2"),
    (with_step({"op": "argmin", "inputs": [1], "metric": "segment_distance"}), 4, "inputs",
     "takes 3 inputs"),
    (with_step({"op": "argmax", "inputs": [1, 2, 3, 0], "metric": "segment_distance"}), 4,
     "inputs", "1 to 3"),
    (with_step({"op": "middle", "inputs": [1], "metric": "rightward"}), 4, "viewpoint",
     "metric 'rightward' needs"),
    (
        with_step({"op": "middle", "inputs": [1], "metric": "height",
                   "viewpoint": {"eye": [0, 0, 0], "target": [1, 0, 0]}}),
        4, "viewpoint", "metrics 'rightward' and 'forward'",
    ),
    (
        with_step({"op": "match_text", "inputs": [0], "value": "cup", "k": 0}),
        4, "k", "greater than or equal to 1",
    ),
    (with_step({"op": "filter_attribute", "inputs": [0], "value": "red"}), 4, "value", "key=value"),
    (with_step({"op": "filter_attribute", "inputs": [0], "value": "c="}), 4, "value", "key=value"),
    (with_step({"op": "filter_category", "inputs": [0], "value": "  \t"}), 4, "value", "empty"),
    (with_step({"op": "filter_category", "inputs": [0], "value": "a\x00b"}), 4, "value", "NUL"),
    (with_step({"op": "filter_category", "inputs": [0], "value": "\ud800"}), 4, "value", "unicode"),
    (with_step({"op": "frobnicate", "inputs": [0]}), 4, "op", "Input should be"),
    (
        with_step({"op": "relate", "inputs": [2, 1], "relation": "beside"}),
        4, "relation", "Input should be",
    ),
    (with_step({"op": "count", "inputs": [True]}), 4, "inputs[0]", "integer"),
    (with_step({"op": "count", "inputs": ["1"]}), 4, "inputs[0]", "integer"),
    (with_step({"op": "count", "inputs": [-1]}), 4, "inputs[0]", "greater than or equal to 0"),
    (with_step({"op": "count", "inputs": [1], "colour": "red"}), 4, "colour", "not a field"),
    (
        with_step({"op": "count", "inputs": [3]}) | {"answer_step": 5},
        None, "answer_step", "not a step",
    ),
    (SPATIAL | {"query_type": "intrinsic"}, 3, "op", "intrinsic"),
    (SPATIAL | {"query_type": "gossip"}, None, "query_type", "Input should be"),
    ({k: v for k, v in SPATIAL.items() if k != "answer_step"}, None, "answer_step", "required"),
    (SPATIAL | {"steps": []}, None, "steps", "at least 1"),
    (SPATIAL | {"steps": [{"op": "scene"}] * (MAX_STEPS + 1)}, None, "steps", "at most"),
    (SPATIAL | {"extra": 1}, None, "extra", "not a field"),
]  # fmt: skip


@pytest.mark.parametrize(("doc", "step", "field", "words"), INVALID)
def test_invalid_programs_name_the_step_and_field(
    doc: dict[str, Any], step: int | None, field: str, words: str
) -> None:
    with pytest.raises(QueryValidationError) as info:
        GraphQuery.parse(doc)
    err = info.value
    assert (err.step, err.field) == (step, field), str(err)
    assert words in str(err)
    prefix = f"step {step}: " if step is not None else ""
    assert str(err).startswith(f"{prefix}field {field!r}: ")


def test_count_results_are_not_set_inputs() -> None:
    doc = with_step({"op": "count", "inputs": [3]})
    doc["steps"].append({"op": "union", "inputs": [3, 4]})
    with pytest.raises(QueryValidationError) as info:
        GraphQuery.parse(doc)
    assert (info.value.step, info.value.field) == (5, "inputs[1]")
    assert "not a set" in str(info.value)


def test_direct_construction_and_json_errors_are_typed() -> None:
    with pytest.raises(QueryValidationError):
        Step(op="relate", inputs=["x"])
    with pytest.raises(QueryValidationError):
        GraphQuery(query_type="spatial", steps=[{"op": "count", "inputs": [0]}], answer_step=0)
    with pytest.raises(QueryValidationError, match="JSON"):
        GraphQuery.parse("{not json")
    with pytest.raises(QueryValidationError, match="JSON object"):
        GraphQuery.parse([1, 2])  # type: ignore[arg-type]
    with pytest.raises(QueryValidationError, match="JSON object"):
        GraphQuery.parse("[1, 2]")


def test_every_op_has_a_spec_and_a_signature() -> None:
    assert set(OP_SPECS) == set(Op)
    assert all(spec.signature.startswith(op.value) for op, spec in OP_SPECS.items())


# -- the JSON Schema ---------------------------------------------------------------------

ALLOWED_KEYWORDS = {
    "title", "description", "type", "enum", "properties", "required", "additionalProperties",
    "items", "minItems", "maxItems", "minimum", "maximum", "minLength", "maxLength",
}  # fmt: skip


def _walk(schema: dict[str, Any], path: str = "$") -> list[tuple[str, dict[str, Any]]]:
    out = [(path, schema)]
    for name, sub in schema.get("properties", {}).items():
        out += _walk(sub, f"{path}.{name}")
    if "items" in schema:
        out += _walk(schema["items"], f"{path}[]")
    return out


def test_schema_is_flat_and_closed() -> None:
    schema = GraphQuery.json_schema()
    for path, node in _walk(schema):
        assert set(node) <= ALLOWED_KEYWORDS, f"{path} uses {set(node) - ALLOWED_KEYWORDS}"
        assert isinstance(node.get("type"), str), f"{path} has no single type"
        if node["type"] == "object":
            assert node["additionalProperties"] is False, path
            assert set(node["required"]) <= set(node["properties"]), path
    text = json.dumps(schema)
    for word in ("$ref", "$defs", "anyOf", "oneOf", "allOf", '"null"'):
        assert word not in text
    step = schema["properties"]["steps"]["items"]
    assert list(step["properties"]) == [
        "op",
        "inputs",
        "value",
        "relation",
        "metric",
        "k",
        "viewpoint",
    ]
    assert step["required"] == ["op"]
    assert step["properties"]["op"]["enum"] == [op.value for op in Op]
    assert GraphQuery.json_schema() is not GraphQuery.json_schema()  # a fresh copy


def conforms(value: Any, schema: dict[str, Any]) -> bool:
    """A validator for exactly the keywords the schema may use."""
    kind = schema["type"]
    if kind == "object":
        if not isinstance(value, dict) or not set(schema["required"]) <= set(value):
            return False
        props = schema["properties"]
        return all(k in props and conforms(v, props[k]) for k, v in value.items())
    if kind == "array":
        return (
            isinstance(value, list)
            and schema.get("minItems", 0) <= len(value) <= schema.get("maxItems", len(value))
            and all(conforms(v, schema["items"]) for v in value)
        )
    if kind == "string":
        return (
            isinstance(value, str)
            and ("enum" not in schema or value in schema["enum"])
            and schema.get("minLength", 0) <= len(value) <= schema.get("maxLength", len(value))
        )
    if kind in ("integer", "number"):
        ok = isinstance(value, int) if kind == "integer" else isinstance(value, int | float)
        return (
            ok
            and not isinstance(value, bool)
            and schema.get("minimum", value) <= value <= schema.get("maximum", value)
        )
    raise AssertionError(f"unexpected schema type {kind}")


@settings(max_examples=150, deadline=None)
@given(programs())
def test_every_valid_program_conforms_to_the_schema(program: GraphQuery) -> None:
    assert conforms(json.loads(program.to_json()), GraphQuery.json_schema())


def test_schema_refuses_what_the_model_refuses() -> None:
    schema = GraphQuery.json_schema()
    assert conforms(SPATIAL, schema)
    assert not conforms(SPATIAL | {"extra": 1}, schema)
    assert not conforms(with_step({"op": "relate", "inputs": [0, 1], "relation": "beside"}), schema)
    assert not conforms(
        with_step({"op": "match_text", "inputs": [0], "value": "a", "k": 0}), schema
    )
