"""Metrics and the queries-file evaluation, against hand-computed values."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from causalsplat.eval.reasoning import (
    box_iou,
    evaluate_queries,
    mask_iou,
    parse_queries,
    read_queries,
    referit_correct,
    set_f1,
    set_iou,
)
from causalsplat.reason import QueriesFileError, SceneContext
from causalsplat.reason.offline import OfflineReasoner


def test_hand_values() -> None:
    # points of different objects are disjoint: IoU = shared points / union points
    assert set_iou([1, 2], [2, 3], {1: 10, 2: 30, 3: 60}) == pytest.approx(30 / 100)
    assert set_iou([1, 2], [2, 3]) == pytest.approx(1 / 3)
    assert set_iou([], []) == 1.0 and set_iou([1], []) == 0.0
    assert set_f1([1, 2], [2, 3]) == pytest.approx(0.5)
    assert set_f1([], []) == 1.0 and set_f1([4], [5]) == 0.0
    a = np.array([1, 1, 0, 0], dtype=bool)
    b = np.array([0, 1, 1, 0], dtype=bool)
    assert mask_iou(a, b) == pytest.approx(1 / 3)
    assert box_iou((0, 0, 0), (2, 1, 1), (1, 0, 0), (3, 1, 1)) == pytest.approx(1 / 3)
    assert box_iou((0, 0, 0), (1, 1, 1), (2, 2, 2), (3, 3, 3)) == 0.0
    assert referit_correct((5,), 5) and not referit_correct((5, 6), 5)


@given(
    st.sets(st.integers(0, 8)),
    st.sets(st.integers(0, 8)),
    st.lists(st.floats(0.5, 100.0), min_size=9, max_size=9),
)
def test_iou_properties(p: set[int], t: set[int], w: list[float]) -> None:
    weights = dict(enumerate(w))
    value = set_iou(p, t, weights)
    assert 0.0 <= value <= 1.0
    assert value == pytest.approx(set_iou(t, p, weights))
    assert (value == pytest.approx(1.0)) == (p == t)
    labels = np.repeat(np.arange(9), 3)
    assert mask_iou(np.isin(labels, list(p)), np.isin(labels, list(t))) == pytest.approx(
        set_iou(p, t)
    )


@pytest.mark.parametrize(
    ("document", "message"),
    [
        ([], "'queries' list"),
        ({"queries": [{"id": "a", "text": "", "type": "spatial", "targets": []}]}, "text"),
        ({"queries": [{"id": "a", "text": "x", "type": "magic", "targets": []}]}, "type"),
        ({"queries": [{"id": "a", "text": "x", "type": "spatial", "targets": [True]}]}, "targets"),
    ],
)
def test_bad_queries_files_name_the_field(document: object, message: str) -> None:
    with pytest.raises(QueriesFileError, match=message):
        parse_queries(document)


def test_evaluate_scores_per_type(room: SceneContext, tmp_path: Path) -> None:
    doc = {
        "scene_id": "room",
        "queries": [
            {"id": "q1", "text": "the chair closest to the lamp", "type": "spatial",
             "targets": [6]},
            {"id": "q2", "text": "the chair closest to the lamp", "type": "spatial",
             "targets": [5]},
            {"id": "q3", "text": "if the table is removed, what falls?", "type": "counterfactual",
             "targets": [2, 3]},
            {"id": "q4", "text": "the piano", "type": "intrinsic", "targets": [9]},
        ],
    }  # fmt: skip
    path = tmp_path / "q.json"
    path.write_text(json.dumps(doc))
    report = evaluate_queries(room, read_queries(path), OfflineReasoner())
    assert report.n == 4 and report.iou_basis == "entities"
    assert report.accuracy == pytest.approx(1 / 4)
    out = {o.id: o for o in report.per_query}
    assert out["q1"].correct and out["q1"].iou == 1.0
    assert not out["q2"].correct and out["q2"].iou == 0.0
    # predicted {2, 3, 4} vs targets {2, 3}: IoU 2/3, F1 0.8
    assert out["q3"].iou == pytest.approx(2 / 3) and out["q3"].f1 == pytest.approx(0.8)
    # a sentence naming nothing here is answered with nothing, not an error
    assert out["q4"].error is None and out["q4"].predicted == () and not out["q4"].correct
    assert report.by_type["spatial"].n == 2 and report.by_type["spatial"].accuracy == 0.5
    document = report.to_dict()
    assert {"n", "accuracy", "miou", "by_type", "per_query"} <= set(document)
    assert set(document["by_type"]["spatial"]) >= {"n", "accuracy", "miou"}
    bad = {"scene_id": "room", "queries": [{"id": "x", "text": "t", "type": "spatial",
                                           "targets": [77]}]}  # fmt: skip
    with pytest.raises(QueriesFileError, match="target '77'"):
        evaluate_queries(room, parse_queries(bad), OfflineReasoner())
