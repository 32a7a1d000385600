"""Fuzzing the ways in: whatever JSON (or text) comes in, the only exception that can
escape is QueryValidationError; what is accepted is a valid program."""

from __future__ import annotations

import contextlib
import json
from typing import Any

from hypothesis import given, settings
from hypothesis import strategies as st

from queries import GraphQuery, QueryValidationError
from tests.queries.query_strategies import programs

KEYS = ["query_type", "steps", "answer_step", "op", "inputs", "value", "relation", "metric",
        "k", "viewpoint", "eye", "target"]  # fmt: skip
WORDS = ["spatial", "intrinsic", "scene", "relate", "argmin", "middle", "count", "near",
         "left_of", "distance", "z", "color=red", "sink"]  # fmt: skip

scalars = (
    st.none()
    | st.booleans()
    | st.integers(-(2**70), 2**70)
    | st.floats()
    | st.text(max_size=12)
    | st.sampled_from(WORDS)
)
json_values = st.recursive(
    scalars,
    lambda inner: (
        st.lists(inner, max_size=5)
        | st.dictionaries(st.sampled_from(KEYS) | st.text(max_size=6), inner, max_size=6)
    ),
    max_leaves=30,
)


def accepts_or_refuses(value: Any) -> None:
    """Parse ``value``; only a valid program or QueryValidationError may come out."""
    try:
        program = GraphQuery.parse(value)
    except QueryValidationError as err:
        assert str(err)
        return
    assert isinstance(program, GraphQuery)
    assert GraphQuery.parse(program.to_json()) == program


@settings(max_examples=300, deadline=None)
@given(json_values)
def test_arbitrary_json_values(value: Any) -> None:
    accepts_or_refuses(value if isinstance(value, dict) else {"steps": value})
    try:
        text = json.dumps(value, allow_nan=True)
    except ValueError:
        return
    accepts_or_refuses(text)


@settings(max_examples=200, deadline=None)
@given(st.binary(max_size=64) | st.text(max_size=64))
def test_arbitrary_bytes_and_text(data: bytes | str) -> None:
    accepts_or_refuses(data)


@st.composite
def mutated(draw: st.DrawFn) -> Any:
    """A valid program with a few random edits to its JSON object."""
    doc: Any = draw(programs()).to_dict()
    for _ in range(draw(st.integers(1, 3))):
        steps = doc.get("steps")
        inner = [s for s in steps if isinstance(s, dict)] if isinstance(steps, list) else []
        target = draw(st.sampled_from([doc, *inner]))
        key = draw(st.sampled_from(KEYS))
        action = draw(st.sampled_from(["set", "delete", "nudge"]))
        if action == "delete":
            target.pop(key, None)
        elif action == "nudge" and isinstance(target.get(key), int):
            target[key] += draw(st.integers(-3, 3))
        elif action == "nudge" and isinstance(target.get(key), list) and target[key]:
            target[key][draw(st.integers(0, len(target[key]) - 1))] = draw(json_values)
        else:
            target[key] = draw(json_values)
    return doc


@settings(max_examples=400, deadline=None)
@given(mutated())
def test_mutated_valid_programs(doc: Any) -> None:
    accepts_or_refuses(doc)
    accepts_or_refuses(json.dumps(doc))


@settings(max_examples=300, deadline=None)
@given(programs(), st.data())
def test_mutated_text_forms(program: GraphQuery, data: st.DataObject) -> None:
    text = program.to_text()
    pos = data.draw(st.integers(0, len(text)))
    cut = data.draw(st.integers(0, 4))
    junk = data.draw(st.text(alphabet='v0123456789=(),"\\ \n#-.eknvalue', max_size=4))
    edited = text[:pos] + junk + text[pos + cut :]
    try:
        parsed = GraphQuery.from_text(edited)
    except QueryValidationError as err:
        assert err.field in ("text", "query_type", "answer_step") or err.step is not None
        return
    assert GraphQuery.from_text(parsed.to_text()) == parsed


@settings(max_examples=200, deadline=None)
@given(st.text(max_size=80))
def test_arbitrary_text_forms(text: str) -> None:
    with contextlib.suppress(QueryValidationError):
        GraphQuery.from_text(text)
