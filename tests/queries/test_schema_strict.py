"""The program's schema for OpenAI's strict structured-output mode, checked by a validator
of strict-mode rules (the one the loopback VLM server refuses requests with), and the model
reading the nulls a strict-mode reply writes."""

from __future__ import annotations

import json
import re
from typing import Any

import pytest
from hypothesis import given, settings

from graph_store.types import RelationType
from queries import GraphQuery, Metric, QueryValidationError
from queries.model import (
    MAX_K,
    MAX_SET_INPUTS,
    MAX_STEPS,
    MAX_VALUE_LENGTH,
    OP_SPECS,
    STEP_FIELDS,
)
from queries.schema import (
    graph_query_schema,
    graph_query_schema_by_op,
    graph_query_strict_schema,
    strict_schema,
    strict_string_pattern,
)
from tests.causalsplat.reason.vlm_server import strict_schema_problems
from tests.queries.query_strategies import programs
from tests.queries.test_query_model import SPATIAL


def test_the_strict_schema_passes_strict_mode_rules() -> None:
    assert strict_schema_problems(graph_query_strict_schema()) == []


def test_the_flat_schema_breaks_them_and_is_unchanged() -> None:
    graph_query_strict_schema()
    flat = GraphQuery.json_schema()
    assert flat["properties"]["steps"]["items"]["required"] == ["op"]
    problems = strict_schema_problems(flat)
    assert any("Missing ['inputs', 'k', 'metric', 'relation', 'value', 'viewpoint']" in p
               for p in problems)  # fmt: skip
    assert any("'maxLength', 'minLength' is not permitted" in p for p in problems)
    assert flat == graph_query_schema()


@pytest.mark.parametrize(
    ("schema", "words"),
    [
        ({"type": "object", "properties": {"a": {"type": "string"}}, "required": ["a"]},
         "'additionalProperties' is required to be false"),
        ({"type": "object", "properties": {"a": {"type": "string"}}, "required": [],
          "additionalProperties": False}, "Missing ['a']"),
        ({"type": "object", "properties": {"a": {"anyOf": [
            {"type": "object", "properties": {"b": {"type": "integer"}},
             "additionalProperties": False}, {"type": "null"}]}},
          "required": ["a"], "additionalProperties": False}, "$.a.anyOf[0]: 'required'"),
        ({"type": "object", "properties": {"a": {"type": "array", "items": {
            "type": "object", "properties": {}, "required": []}}},
          "required": ["a"], "additionalProperties": False}, "$.a[]: 'additionalProperties'"),
        ({"type": "object", "properties": {}, "required": [], "additionalProperties": False,
          "$defs": {"d": {"type": "object", "properties": {"x": {"type": "string"}},
                          "required": ["x"]}}}, "$defs.d: 'additionalProperties'"),
        ({"type": "object", "properties": {"a": {"type": "string", "maxLength": 3}},
          "required": ["a"], "additionalProperties": False}, "'maxLength' is not permitted"),
        ({"anyOf": [{"type": "object"}]}, "the root must be an object"),
    ],
)  # fmt: skip
def test_the_checker_finds_each_rule_broken(schema: dict[str, Any], words: str) -> None:
    problems = strict_schema_problems(schema)
    assert any(words in p for p in problems), problems


def test_every_step_property_is_required_and_optional_ones_are_nullable() -> None:
    schema = graph_query_strict_schema()
    assert "title" not in schema
    assert schema["properties"]["steps"]["maxItems"] == MAX_STEPS
    step = schema["properties"]["steps"]["items"]
    assert step["required"] == ["op", "inputs", *STEP_FIELDS]
    props = step["properties"]
    assert props["inputs"]["type"] == "array" and props["inputs"]["maxItems"] == MAX_SET_INPUTS
    for name in STEP_FIELDS:
        assert props[name]["anyOf"][1] == {"type": "null"}, name
    assert props["k"]["anyOf"][0] == {"type": "integer", "minimum": 1, "maximum": MAX_K}
    assert props["value"]["anyOf"][0]["pattern"] == strict_string_pattern(1, MAX_VALUE_LENGTH)
    viewpoint = props["viewpoint"]["anyOf"][0]
    assert viewpoint["required"] == ["eye", "target"]


def test_string_bounds_become_a_pattern_of_plain_characters() -> None:
    pattern = re.compile(strict_string_pattern(1, 5))
    assert [bool(pattern.search(s)) for s in ("sink", "café", "a=b c", "x" * 5)] == [True] * 4
    bad = ("", "x" * 6, 'say "hi"', "back\\slash", "line\nbreak", "tab\there")
    assert [bool(pattern.search(s)) for s in bad] == [False] * len(bad)
    with pytest.raises(ValueError, match="maxLength"):
        strict_schema({"type": "string", "minLength": 1})


def conforms_strict(value: Any, schema: dict[str, Any]) -> bool:
    """A validator for the keywords of the strict schema (``anyOf``, ``null``, ``pattern``)."""
    if "anyOf" in schema:
        return any(conforms_strict(value, option) for option in schema["anyOf"])
    kind = schema["type"]
    if kind == "null":
        return value is None
    if kind == "object":
        props = schema["properties"]
        return (
            isinstance(value, dict)
            and set(value) == set(schema["required"]) == set(props)
            and all(conforms_strict(v, props[k]) for k, v in value.items())
        )
    if kind == "array":
        return (
            isinstance(value, list)
            and schema.get("minItems", 0) <= len(value) <= schema.get("maxItems", len(value))
            and all(conforms_strict(v, schema["items"]) for v in value)
        )
    if kind == "string":
        return (
            isinstance(value, str)
            and ("enum" not in schema or value in schema["enum"])
            and ("pattern" not in schema or re.search(schema["pattern"], value) is not None)
        )
    if kind in ("integer", "number"):
        ok = isinstance(value, int) if kind == "integer" else isinstance(value, int | float)
        return (
            ok
            and not isinstance(value, bool)
            and schema.get("minimum", value) <= value <= schema.get("maximum", value)
        )
    raise AssertionError(f"unexpected schema type {kind}")


def strict_form(program: GraphQuery) -> dict[str, Any]:
    """The program as a strict-mode reply writes it: every step property, nulls for unset."""
    doc = program.to_dict()
    doc["steps"] = [
        {"op": s["op"], "inputs": s.get("inputs", []), **{f: s.get(f) for f in STEP_FIELDS}}
        for s in doc["steps"]
    ]
    return doc


def _plain(program: GraphQuery) -> bool:
    pattern = re.compile(strict_string_pattern(1, MAX_VALUE_LENGTH))
    return all(s.value is None or pattern.search(s.value) for s in program.steps)


@settings(max_examples=150, deadline=None)
@given(programs())
def test_strict_replies_conform_and_read_back(program: GraphQuery) -> None:
    doc = strict_form(program)
    # Strings with a quote, backslash or control character are left out of strict-mode
    # replies on purpose (see queries.schema); everything else conforms.
    assert conforms_strict(doc, graph_query_strict_schema()) == _plain(program)
    assert GraphQuery.parse(doc) == program
    assert GraphQuery.parse(json.dumps(doc)) == program


def test_null_inputs_mean_none() -> None:
    doc = {"query_type": "intrinsic", "steps": [{"op": "scene", "inputs": None}], "answer_step": 0}
    assert GraphQuery.parse(doc).steps[0].inputs == ()
    bad = json.loads(json.dumps(SPATIAL))
    bad["steps"][1]["inputs"] = None  # filter_category needs its input
    with pytest.raises(QueryValidationError, match="step 1: field 'inputs'"):
        GraphQuery.parse(bad)


def test_more_steps_than_the_schema_allows_are_refused() -> None:
    scene = {"op": "scene", "inputs": [], **dict.fromkeys(STEP_FIELDS)}
    doc = {"query_type": "intrinsic", "steps": [scene] * (MAX_STEPS + 1), "answer_step": 0}
    assert not conforms_strict(doc, graph_query_strict_schema())
    with pytest.raises(QueryValidationError, match=f"field 'steps': .*at most {MAX_STEPS}"):
        GraphQuery.parse(doc)
    doc["steps"] = doc["steps"][:MAX_STEPS]
    assert conforms_strict(doc, graph_query_strict_schema())
    assert len(GraphQuery.parse(doc).steps) == MAX_STEPS


def by_op_form(program: GraphQuery) -> dict[str, Any]:
    """The program as a reply under the per-op schema writes it: each step with its op's
    fields only (nulls for the unset optional ones)."""
    strict = strict_schema(graph_query_schema_by_op())
    variants = strict["properties"]["steps"]["items"]["anyOf"]
    doc = program.to_dict()
    steps = []
    for s in doc["steps"]:
        step = {"op": s["op"], "inputs": s.get("inputs", []), **{f: s.get(f) for f in STEP_FIELDS}}
        fields = next(
            v["properties"]
            for v in variants
            if v["properties"]["op"]["enum"] == [s["op"]]
            and ("relation" not in v["properties"]
                 or s.get("relation") in v["properties"]["relation"]["enum"])
            and ("metric" not in v["properties"]
                 or s.get("metric") in v["properties"]["metric"]["enum"])
        )  # fmt: skip
        steps.append({k: step[k] for k in fields})
    doc["steps"] = steps
    return doc


def test_the_per_op_schema_passes_strict_mode_rules() -> None:
    strict = strict_schema(graph_query_schema_by_op())
    assert strict_schema_problems(strict) == []
    variants = strict["properties"]["steps"]["items"]["anyOf"]
    # relate: with and without a viewpoint; argmin, argmax, middle: seen from a viewpoint,
    # measured to segments between two ends, the rest
    assert len(variants) == len(OP_SPECS) + 1 + 3 * 2
    for v in variants:
        fields = v["properties"]
        spec = OP_SPECS[fields["op"]["enum"][0]]
        arity = (fields["inputs"]["minItems"], fields["inputs"]["maxItems"])
        if "metric" not in fields:
            assert arity == (spec.min_inputs, spec.max_inputs)
        else:
            metrics = [Metric(m) for m in fields["metric"]["enum"]]
            ends, seen = metrics[0].is_segment, metrics[0].is_seen_from
            assert all(m.is_segment is ends and m.is_seen_from is seen for m in metrics)
            assert arity == ((3, 3) if ends else (1, 1) if seen else (1, 2))
        assert set(fields) <= {"op", "inputs", *spec.required, *spec.optional}
        if "viewpoint" in fields:  # only where the relation or metric is seen from somewhere
            if "relation" in fields:
                assert all(RelationType(r).is_view_dependent for r in fields["relation"]["enum"])
            else:
                assert fields["metric"]["enum"] == ["rightward", "forward"]


@settings(max_examples=150, deadline=None)
@given(programs())
def test_every_program_fits_the_per_op_schema_and_reads_back(program: GraphQuery) -> None:
    doc = by_op_form(program)
    strict = strict_schema(graph_query_schema_by_op())
    assert conforms_strict(doc, strict) == _plain(program)
    assert GraphQuery.parse(doc) == program


def test_the_per_op_schema_has_no_room_for_a_field_the_op_does_not_take() -> None:
    strict = strict_schema(graph_query_schema_by_op())
    step = {"op": "filter_category", "inputs": [0], "value": "sink"}
    doc = {"query_type": "intrinsic", "steps": [{"op": "scene", "inputs": []}, step],
           "answer_step": 1}  # fmt: skip
    assert conforms_strict(doc, strict)
    zeros = {"eye": [0.0, 0.0, 0.0], "target": [0.0, 0.0, 0.0]}
    doc["steps"][1] = {**step, "viewpoint": zeros}
    assert not conforms_strict(doc, strict)
    near = {"op": "relate", "inputs": [0, 0], "relation": "near", "viewpoint": None}
    doc["steps"][1] = near
    assert not conforms_strict(doc, strict)  # near is not seen from a viewpoint
    doc["steps"][1] = {**near, "relation": "left_of"}
    assert conforms_strict(doc, strict)
    doc["steps"][1] = {"op": "filter_category", "inputs": [], "value": "sink"}
    assert not conforms_strict(doc, strict)  # its one input is required


def test_the_per_op_schema_takes_middle_without_k() -> None:
    strict = strict_schema(graph_query_schema_by_op())
    variants = [
        v["properties"]
        for v in strict["properties"]["steps"]["items"]["anyOf"]
        if v["properties"]["op"]["enum"] == ["middle"]
    ]
    assert len(variants) == 3 and all("k" not in v for v in variants)
    assert sorted(m for v in variants for m in v["metric"]["enum"]) == sorted(
        m.value for m in Metric
    )
    steps = [
        {"op": "scene", "inputs": []},
        {"op": "filter_category", "inputs": [0], "value": "towel"},
    ]
    doc = {"query_type": "spatial", "steps": steps, "answer_step": 2}
    plain = {"op": "middle", "inputs": [1, 0], "metric": "distance"}
    seen = {
        "op": "middle",
        "inputs": [1],
        "metric": "rightward",
        "viewpoint": {"eye": [0.0, 0.0, 1.0], "target": [1.0, 0.0, 1.0]},
    }
    for step in (plain, seen):
        doc["steps"] = [*steps, step]
        assert conforms_strict(doc, strict), step
        assert GraphQuery.parse(doc).steps[2].op.value == "middle"
        doc["steps"] = [*steps, {**step, "k": 2}]
        assert not conforms_strict(doc, strict)  # middle keeps no k
        with pytest.raises(QueryValidationError, match="field 'k'"):
            GraphQuery.parse(doc)
    doc["steps"] = [*steps, {**plain, "viewpoint": seen["viewpoint"]}]
    assert not conforms_strict(doc, strict)  # distance is not seen from a viewpoint
    doc["steps"] = [*steps, {**plain, "inputs": [1, 0, 0]}]
    assert not conforms_strict(doc, strict)  # at most two inputs
