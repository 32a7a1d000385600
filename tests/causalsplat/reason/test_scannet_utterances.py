"""The offline reasoner on the real Sr3D / Nr3D / ScanRefer utterances of ScanNet
scene0000_00, with the scan's ground-truth objects ingested with our edges."""

from __future__ import annotations

import contextlib
import csv
import json
from pathlib import Path

import pytest

from causalsplat.bench._reasoning_referit import objects_document
from causalsplat.objects import objects_to_scene_graph, parse_objects
from causalsplat.reason import InstructionError, SceneContext
from causalsplat.reason.offline import OfflineReasoner
from tests.conftest import shared_data_path

pytestmark = pytest.mark.shared_data


@pytest.fixture(scope="module")
def scene0000() -> SceneContext:
    root = shared_data_path("referit3d_scannet_objects")
    graph = objects_to_scene_graph(parse_objects(objects_document("scene0000_00", root)))
    return SceneContext(graph)


def _rows(name: str) -> list[dict[str, str]]:
    path: Path = shared_data_path("scannet_scene0000_00", "language_gt", name)
    with path.open(encoding="utf-8", newline="") as handle:
        return list(csv.DictReader(handle))


def _accuracy(ctx: SceneContext, pairs: list[tuple[str, int]]) -> float:
    reasoner = OfflineReasoner()
    correct = 0
    for text, target in pairs:
        with contextlib.suppress(InstructionError):
            correct += reasoner.answer(text, ctx).entity_ids == (target,)
    return correct / len(pairs)


def test_the_documented_example(scene0000: SceneContext) -> None:
    answer = OfflineReasoner().answer(
        "the toaster between the sink and the toaster oven", scene0000
    )
    assert answer.entity_ids == (53,)


def test_sr3d_rows_of_scene0000(scene0000: SceneContext) -> None:
    pairs = [(r["utterance"], int(r["target_id"])) for r in _rows("sr3d_scene0000_00.csv")]
    assert len(pairs) == 70
    # Measured 66/70: every between, above, below, supported-by, left and right row; the
    # four "in front of" rows are missed (the scan has no object orientations).
    assert _accuracy(scene0000, pairs) >= 0.9


def test_nr3d_and_scanrefer_of_scene0000(scene0000: SceneContext) -> None:
    nr3d = [(r["utterance"], int(r["target_id"])) for r in _rows("nr3d_scene0000_00.csv")]
    path = shared_data_path("scannet_scene0000_00", "language_gt", "scanrefer_scene0000_00.json")
    scanrefer = [(r["description"], int(r["object_id"])) for r in json.loads(path.read_text())]
    assert len(nr3d) == 11 and len(scanrefer) == 5
    # Human-written; measured 8/11 and 4/5.
    assert _accuracy(scene0000, nr3d) >= 0.6
    assert _accuracy(scene0000, scanrefer) >= 0.6
