"""The DDN demand protocol (``ddn_demands/SOURCE.md``) on the *train* split: placements,
scoring, the naive baseline, and that the reasoner answers every placed instruction."""

from __future__ import annotations

from pathlib import Path

import pytest

from causalsplat.bench import _reasoning_ddn as ddn
from causalsplat.bench import _reasoning_referit as ref
from causalsplat.reason.embed import embeddings_available
from causalsplat.reason.offline import OfflineReasoner
from tests.conftest import shared_data_path

pytestmark = pytest.mark.shared_data


@pytest.fixture(scope="module")
def placed() -> list[ddn.Placement]:
    shared_data_path("ddn_demands", "instruction_train_check.json")
    shared_data_path("referit3d_scannet_objects", "objects_info")
    rows, total = ddn.placements("train")
    assert total == 1692 and 1300 <= len(rows) <= total
    return rows


def test_placements_follow_the_protocol(placed: list[ddn.Placement]) -> None:
    labels = ddn.scan_labels()
    for row in placed[:200]:
        scan = labels[row.scan]
        assert scan & row.acceptable
        assert len(scan - row.acceptable - ddn._NOT_COUNTED) >= ddn.MIN_OTHER_LABELS
    again, _ = ddn.placements("train")
    assert again == placed  # seeded by the text: the same scans every run


def test_every_placed_instruction_gets_an_answer(
    placed: list[ddn.Placement], tmp_path: Path
) -> None:
    rows = placed[::40]  # 35 instructions in as many scans
    graphs = ref.ScanGraphs(f"sqlite:///{tmp_path / 'ddn.db'}")
    try:
        outcomes = ddn.evaluate(rows, OfflineReasoner(), graphs)
        summary = ddn.summary(outcomes)
        assert summary["n"] == len(rows) and summary["errors"] == 0
        assert summary["empty"] <= 0.05
        assert all(o.ranked for o in outcomes)  # ranked candidates on every answer
        # right means non-empty and every label acceptable
        for o in outcomes:
            assert o.right == (bool(o.labels) and set(o.labels) <= o.placement.acceptable)
        if embeddings_available():
            base = ddn.summary(ddn.baseline(rows, graphs))
            assert base["n"] == len(rows)
            # on the development split the reasoner is well above the one-line baseline
            assert summary["accuracy"] > base["accuracy"]
    finally:
        graphs.close()
