"""A scene whose masks come as SAM writes them: no labels, COCO RLE JSON per image."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from causalsplat.masks.files import read_masks
from tests.causalsplat.reason.vlm_server import Reply, ScriptedServer
from tests.causalsplat.test_cli_store import assert_one_line_error, run

mask_utils = pytest.importorskip("pycocotools.mask")
pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")  # pycocotools on numpy 2


def _as_sam_json(masks_dir: Path, out: Path) -> None:
    """Each view's masks as SAM's automatic mask generator writes them (no labels)."""
    import numpy as np

    out.mkdir()
    for path in sorted(masks_dir.glob("*.npz")):
        maskset = read_masks(path)
        annotations = []
        for i, mask in enumerate(maskset.masks):
            rle = mask_utils.encode(np.asfortranarray(mask.astype(np.uint8)))
            rle["counts"] = rle["counts"].decode("utf-8")
            score = 0.9 if maskset.scores is None else float(maskset.scores[i])
            annotations.append({"segmentation": rle, "area": int(mask.sum()),
                                "predicted_iou": score, "stability_score": 0.95})  # fmt: skip
        (out / f"{path.stem}.json").write_text(json.dumps(annotations))


@pytest.fixture
def sam_scene(tiny_folder: Path, tmp_path: Path) -> Path:
    """The tiny scene with its masks replaced by SAM's JSON, converted by the CLI."""
    scene = tmp_path / "scene"
    shutil.copytree(tiny_folder, scene, ignore=shutil.ignore_patterns("masks"))
    _as_sam_json(tiny_folder / "masks", tmp_path / "sam")
    converted = json.loads(
        run(
            "masks",
            "convert",
            str(tmp_path / "sam"),
            "-o",
            str(scene / "masks"),
            "--scene",
            str(scene),
            "--json",
        ).stdout
    )
    assert converted["views"] == 12 and converted["labelled_views"] == 0  # fmt: skip
    return scene


def test_unlabelled_sam_masks_build_with_a_warning_and_ask_says_what_is_missing(
    sam_scene: Path, tmp_path: Path
) -> None:
    scene = sam_scene
    db = f"sqlite:///{tmp_path / 's.db'}"
    config = tmp_path / "fast.json"
    config.write_text(json.dumps({"field": {"iterations": 20}}))
    built = run("build", str(scene), "--config", str(config), "--no-cache", "--json", db=db)
    doc = json.loads(built.stdout)
    assert doc["entities"] > 0
    assert [w for w in doc["warnings"] if "carry no labels" in w and "--labeler vlm" in w]
    asked = run("ask", "where can I wash my hands?", "--scene", doc["scene_id"], db=db,
                check=False)  # fmt: skip
    assert_one_line_error(asked, "has no categories")
    assert "--labeler vlm" in asked.stderr


def test_unlabelled_sam_masks_are_named_by_a_vlm_labeller(
    sam_scene: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    label = json.dumps({"category": "Armchair", "color": "green", "material": "fabric",
                        "state": "", "affordances": ["sit"]})  # fmt: skip
    db = f"sqlite:///{tmp_path / 'v.db'}"
    config = tmp_path / "fast.json"
    config.write_text(json.dumps({"field": {"iterations": 20}}))
    with ScriptedServer() as server:
        server.script.extend([Reply(label)] * 64)
        monkeypatch.setenv("CAUSALSPLAT_VLM_BASE_URL", server.base_url)
        monkeypatch.setenv("CAUSALSPLAT_VLM_MODEL", "vlm-test")
        built = run("build", str(sam_scene), "--config", str(config), "--no-cache",
                    "--labeler", "vlm", "--json", db=db)  # fmt: skip
        requests = len(server.requests)
    doc = json.loads(built.stdout)
    assert doc["entities"] > 0 and requests == doc["entities"]
    assert not [w for w in doc["warnings"] if "carry no labels" in w]
    asked = json.loads(run("ask", "somewhere to sit down", "--scene", doc["scene_id"], "--json",
                           db=db).stdout)  # fmt: skip
    assert asked["entities"] and {e["category"] for e in asked["entities"]} == {"armchair"}
