"""The text form: canonical printing, exact round trips, and parse errors."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from queries import GraphQuery, QueryValidationError
from tests.queries.query_strategies import programs

EXAMPLE = """query spatial
v0 = scene()
v1 = filter_category(v0, "sink")
v2 = filter_category(v0, "towel")
v3 = relate(v2, v1, left_of, viewpoint=(0.0, -1.5, 1.2)->(2.0, 1e-05, 0.8))
v4 = argmin(v3, v1, distance, k=2)
v5 = match_text(v0, "say \\"hi\\"\\n\\u2028", k=3)
v6 = count(v4)
return v4"""


def test_example_parses_to_the_expected_program() -> None:
    q = GraphQuery.from_text(EXAMPLE)
    assert q.answer_step == 4
    assert q.steps[3].relation is not None and q.steps[3].relation.value == "left_of"
    assert q.steps[3].viewpoint is not None
    assert q.steps[3].viewpoint.eye == (0.0, -1.5, 1.2)
    assert q.steps[3].viewpoint.target == (2.0, 1e-05, 0.8)
    assert q.steps[4].to_dict() == {"op": "argmin", "inputs": [3, 1], "metric": "distance", "k": 2}
    assert q.steps[5].value == 'say "hi"\n\u2028'
    assert q.to_text() == EXAMPLE


def test_model_docstring_example() -> None:
    q = GraphQuery.parse(
        {
            "query_type": "spatial",
            "steps": [
                {"op": "scene"},
                {"op": "filter_category", "inputs": [0], "value": "sink"},
                {"op": "filter_category", "inputs": [0], "value": "towel"},
                {"op": "relate", "inputs": [2, 1], "relation": "near"},
            ],
            "answer_step": 3,
        }
    )
    assert q.to_text().splitlines()[-2:] == ["v3 = relate(v2, v1, near)", "return v3"]


@settings(max_examples=300, deadline=None)
@given(programs())
def test_round_trip_is_exact(program: GraphQuery) -> None:
    text = program.to_text()
    again = GraphQuery.from_text(text)
    assert again == program
    assert again.to_text() == text


def test_middle_round_trips() -> None:
    text = """query spatial
v0 = scene()
v1 = filter_category(v0, "sink")
v2 = filter_category(v0, "towel")
v3 = relate(v2, v1, near)
v4 = middle(v3, rightward, viewpoint=(0.0, -1.5, 1.2)->(2.0, 1e-05, 0.8))
v5 = middle(v2, v1, box_distance)
v6 = middle(v2, metric=z)
return v4"""
    q = GraphQuery.from_text(text)
    assert q.steps[4].to_dict() == {
        "op": "middle",
        "inputs": [3],
        "metric": "rightward",
        "viewpoint": {"eye": [0.0, -1.5, 1.2], "target": [2.0, 1e-05, 0.8]},
    }
    assert q.steps[5].to_dict() == {"op": "middle", "inputs": [2, 1], "metric": "box_distance"}
    assert q.steps[6].to_dict() == {"op": "middle", "inputs": [2], "metric": "z"}
    assert q.to_text() == text.replace("metric=z", "z")
    assert GraphQuery.from_text(q.to_text()) == q
    with pytest.raises(QueryValidationError) as info:
        GraphQuery.from_text("query spatial\nv0 = scene()\nv1 = middle(v0, z, k=2)")
    assert (info.value.step, info.value.field) == (1, "k")


@settings(max_examples=200, deadline=None)
@given(st.text(min_size=1, max_size=30).filter(lambda s: s.strip() and "\x00" not in s))
def test_any_value_string_round_trips(value: str) -> None:
    try:
        program = GraphQuery.parse(
            {
                "query_type": "intrinsic",
                "steps": [{"op": "scene"}, {"op": "match_text", "inputs": [0], "value": value}],
                "answer_step": 1,
            }
        )
    except QueryValidationError:
        return  # e.g. a lone surrogate
    text = program.to_text()
    assert len(text.split("\n")) == 4  # no raw line break or separator inside the literal
    assert GraphQuery.from_text(text) == program


def test_keywords_comments_blank_lines_and_default_answer() -> None:
    text = """
    # a comment
    query counterfactual   # trailing comment
    v0 = scene()

    v1 = filter_category(v0, value="table")
    v2 = fall_if_removed(v1)
    """
    q = GraphQuery.from_text(text)
    assert q.answer_step == 2
    assert q.steps[1].value == "table"


@pytest.mark.parametrize(
    ("text", "step", "words"),
    [
        ("v0 = scene()", 0, "must start with 'query TYPE'"),
        ("query spatial\nv1 = scene()", 0, "expected v0"),
        ("query spatial\nv0 = scene(", 0, "expected ')'"),
        ("query spatial\nv0 = scene()\nv1 = filter_category(v0, 'x')", 1, "unexpected character"),
        ("query spatial\nv0 = scene()\nv1 = relate(v0, near, v0)", 1, "must come before"),
        ("query spatial\nv0 = scene()\nv1 = argmin(v0, z, k=1.5)", 1, "k must be an integer"),
        ("query spatial\nv0 = scene()\nv1 = argmin(v0, z, j=2)", 1, "unknown keyword"),
        ('query spatial\nv0 = scene()\nv1 = filter_category(v0, "a", "b")', 1, "twice"),
        ('query spatial\nv0 = scene()\nv1 = filter_category(v0, "\\q")', 1, "bad string"),
        ("query spatial\nv0 = scene()\nreturn v0\nreturn v0", 1, "twice"),
        ("query spatial\nquery spatial", 0, "once"),
    ],
)
def test_text_errors_name_line_and_step(text: str, step: int, words: str) -> None:
    with pytest.raises(QueryValidationError) as info:
        GraphQuery.from_text(text)
    assert info.value.field == "text"
    assert info.value.step == step
    assert words in str(info.value)
    assert "line " in str(info.value)


def test_semantic_errors_from_text_name_the_step() -> None:
    with pytest.raises(QueryValidationError) as info:
        GraphQuery.from_text("query spatial\nv0 = scene()\nv1 = relate(v0, v0)")
    assert (info.value.step, info.value.field) == (1, "relation")
    with pytest.raises(QueryValidationError) as info:
        GraphQuery.from_text("query spatial\nv0 = scene()\nreturn v3")
    assert info.value.field == "answer_step"
    with pytest.raises(QueryValidationError, match="empty program"):
        GraphQuery.from_text("  # nothing\n")
