"""``masks generate`` end to end: SAM's automatic mask generator on CPU with a randomly
initialised ``vit_b`` (no download), its JSON read back by ``masks convert``.

SAM pads every image to 1024 x 1024, so each image costs one full ``vit_b`` image-encoder
pass whatever its size: the module generates once (two small images, a 4 x 4 prompt grid,
thresholds 0 so that random weights still give masks) and its tests share that run.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from causalsplat.errors import MissingDependencyError
from causalsplat.masks.convert import decode_rle, read_sam_json
from causalsplat.masks.files import read_masks
from causalsplat.masks.generate import (
    MODELS,
    CheckpointError,
    GenerateConfig,
    MaskGenerateError,
    generate_masks,
)
from tests.causalsplat.test_cli_store import assert_one_line_error, run

_MISSING = [m for m in ("torch", "segment_anything", "PIL") if importlib.util.find_spec(m) is None]
if _MISSING:
    if os.environ.get("CI", "").lower() == "true":  # CI installs the sam extra: never skip there
        pytest.fail(f"CI lacks {_MISSING}: make test installs the sam extra", pytrace=False)
    pytest.skip(f"not installed: {', '.join(_MISSING)}", allow_module_level=True)

import torch  # noqa: E402
from PIL import Image  # noqa: E402

KEYS = {"segmentation", "area", "bbox", "predicted_iou", "point_coords", "stability_score",
        "crop_box"}  # fmt: skip
FAST = ["--points-per-side", "4", "--pred-iou-thresh", "0", "--stability-score-thresh", "0"]


def _images(folder: Path) -> dict[str, tuple[int, int]]:
    """Two small images with coloured rectangles: a.png 64 x 48 and b.jpg 56 x 40."""
    folder.mkdir()
    a = np.full((48, 64, 3), (90, 140, 90), np.uint8)
    a[10:30, 5:25] = (200, 30, 30)
    a[20:45, 35:60] = (30, 30, 200)
    Image.fromarray(a).save(folder / "a.png")
    b = np.full((40, 56, 3), (230, 230, 230), np.uint8)
    b[5:20, 10:50] = (20, 120, 20)
    b[25:38, 4:16] = (240, 200, 0)
    Image.fromarray(b).save(folder / "b.jpg", quality=95)
    (folder / "notes.txt").write_text("not an image")
    return {"a": (48, 64), "b": (40, 56)}


@dataclass(frozen=True)
class Run:
    images: Path
    sizes: dict[str, tuple[int, int]]
    checkpoint: Path
    output: Path
    proc: subprocess.CompletedProcess[str]


@pytest.fixture(scope="module")
def sam_run(tmp_path_factory: pytest.TempPathFactory) -> Run:
    from causalsplat.masks._torchvision_stand_in import stand_in_modules

    root = tmp_path_factory.mktemp("sam")
    with stand_in_modules():
        from segment_anything import sam_model_registry
    torch.manual_seed(0)
    net = sam_model_registry["vit_b"]()
    checkpoint = root / "vit_b_random.pth"
    torch.save(net.state_dict(), checkpoint)
    del net
    sizes = _images(root / "images")
    output = root / "sam-json"
    proc = run("masks", "generate", str(root / "images"), "-o", str(output),
               "--checkpoint", str(checkpoint), *FAST, "--json")  # fmt: skip
    return Run(root / "images", sizes, checkpoint, output, proc)


def test_generate_writes_sam_json_per_image(sam_run: Run) -> None:
    report = json.loads(sam_run.proc.stdout)
    assert sorted(p.name for p in sam_run.output.iterdir()) == ["a.json", "b.json"]
    progress = sam_run.proc.stderr.strip().splitlines()
    assert [line.split(":")[1].strip() for line in progress] == ["1/2 a.png", "2/2 b.jpg"]
    total = 0
    for view, (h, w) in sam_run.sizes.items():
        annotations = json.loads((sam_run.output / f"{view}.json").read_text())
        assert isinstance(annotations, list) and annotations, view  # thresholds 0: masks
        total += len(annotations)
        for ann in annotations:
            assert set(ann) == KEYS
            rle = ann["segmentation"]
            assert rle["size"] == [h, w] and isinstance(rle["counts"], str)
            mask = decode_rle(rle)
            assert ann["area"] == int(mask.sum()) > 0
            ys, xs = np.nonzero(mask)  # SAM's box: [x0, y0, x1 - x0, y1 - y0], inclusive ends
            assert ann["bbox"] == [xs.min(), ys.min(), xs.max() - xs.min(), ys.max() - ys.min()]
            assert ann["crop_box"] == [0, 0, w, h]
            (x, y), = ann["point_coords"]  # fmt: skip
            assert 0 <= x < w and 0 <= y < h
            assert isinstance(ann["predicted_iou"], float)
            assert isinstance(ann["stability_score"], float)
        read = read_sam_json(sam_run.output / f"{view}.json")
        assert read.view == view and read.masks.shape == (len(annotations), h, w)
        assert np.allclose(read.scores, [a["predicted_iou"] for a in annotations])
    assert report == {"views": 2, "masks": total, "output": str(sam_run.output),
                      "model": "vit_b", "device": "cpu", "seconds": report["seconds"]}  # fmt: skip
    assert report["seconds"] > 0


def test_masks_convert_reads_what_generate_wrote(sam_run: Run, tmp_path: Path) -> None:
    out = tmp_path / "masks"
    converted = json.loads(run("masks", "convert", str(sam_run.output), "-o", str(out),
                               "--json").stdout)  # fmt: skip
    assert converted["views"] == 2 and converted["resampled_views"] == 0
    for view, (h, w) in sam_run.sizes.items():
        masks = read_masks(out / f"{view}.npz")
        annotations = json.loads((sam_run.output / f"{view}.json").read_text())
        assert masks.masks.shape == (len(annotations), h, w)
        assert np.array_equal(masks.masks[0], decode_rle(annotations[0]["segmentation"]))


def test_refused_runs_are_one_line_and_write_nothing(sam_run: Run, tmp_path: Path) -> None:
    out = tmp_path / "out"
    wrong = tmp_path / "vit_h_like.pth"  # a state dict of another architecture
    torch.save({"image_encoder.pos_embed": torch.zeros(1, 64, 64, 1280),
                "image_encoder.blocks.31.norm1.weight": torch.zeros(1280)}, wrong)  # fmt: skip
    base = ["masks", "generate", str(sam_run.images), "-o", str(out)]
    proc = run(*base, "--checkpoint", str(wrong), check=False)
    assert_one_line_error(proc, "does not fit model vit_b: 1 of another shape")
    assert "[1, 64, 64, 1280] in the checkpoint, [1, 64, 64, 768] in vit_b" in proc.stderr
    assert "it looks like a vit_h checkpoint" in proc.stderr
    proc = run(*base, "--checkpoint", str(tmp_path / "missing.pth"), check=False)
    assert_one_line_error(proc, "missing.pth does not exist")
    proc = run(*base, "--checkpoint", str(sam_run.checkpoint), "--model", "vit_s", check=False)
    assert_one_line_error(proc, "unknown model 'vit_s'; known: vit_b, vit_l, vit_h, sam2.1_hiera_t")
    proc = run(*base, "--checkpoint", str(sam_run.checkpoint), "--pred-iou-thresh", "1.5",
               check=False)  # fmt: skip
    assert_one_line_error(proc, "pred_iou_thresh=1.5 must be a number in [0.0, 1.0]")
    assert not out.exists()


def _call(tmp_path: Path, images: Path, checkpoint: Path, **kwargs: object) -> None:
    generate_masks(images, tmp_path / "out", checkpoint, **kwargs)  # type: ignore[arg-type]


def test_bad_inputs_are_typed_errors(sam_run: Run, tmp_path: Path) -> None:
    ckpt = sam_run.checkpoint
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(MaskGenerateError, match=r"empty: no images \(.png, .jpg, .jpeg\)"):
        _call(tmp_path, empty, ckpt)
    with pytest.raises(MaskGenerateError, match="not a folder of images"):
        _call(tmp_path, tmp_path / "nowhere", ckpt)
    bad = tmp_path / "bad"
    bad.mkdir()
    Image.new("RGB", (8, 8)).save(bad / "a.png")
    (bad / "b.jpg").write_bytes(b"\xff\xd8 not really a jpeg")
    with pytest.raises(MaskGenerateError, match=r"b.jpg: cannot read the image"):
        _call(tmp_path, bad, ckpt)
    (bad / "b.jpg").unlink()
    Image.new("RGB", (8, 8)).save(bad / "a.jpg")
    with pytest.raises(MaskGenerateError, match="several images for view 'a'"):
        _call(tmp_path, bad, ckpt)
    with pytest.raises(CheckpointError, match="is a folder"):
        _call(tmp_path, sam_run.images, tmp_path)
    junk = tmp_path / "junk.pth"
    junk.write_bytes(b"hello, not weights")
    with pytest.raises(CheckpointError, match=r"junk\.pth is not a PyTorch weights file"):
        _call(tmp_path, sam_run.images, junk)
    torch.save({"args": argparse.Namespace(lr=0.1), "model": {"w": torch.zeros(2)}}, junk)
    with pytest.raises(CheckpointError, match=r"holds more than weights \(argparse\.Namespace"):
        _call(tmp_path, sam_run.images, junk)
    torch.save({"epoch": torch.tensor(3), "lr": 0.1}, junk)
    with pytest.raises(CheckpointError, match=r"holds no state dict \(names -> tensors\)"):
        _call(tmp_path, sam_run.images, junk)
    with pytest.raises(MaskGenerateError, match="device 'cuda:7' cannot be used"):
        _call(tmp_path, sam_run.images, ckpt, device="cuda:7")
    assert not (tmp_path / "out").exists()
    (tmp_path / "out").write_text("a file")
    with pytest.raises(MaskGenerateError, match="exists and is not a folder"):
        _call(tmp_path, sam_run.images, ckpt)


def test_a_sam2_checkpoint_given_to_sam_is_named(sam_run: Run, tmp_path: Path) -> None:
    sam2_like = tmp_path / "sam2.pt"
    torch.save({"model": {"maskmem_tpos_enc": torch.zeros(7, 1, 1, 64)}}, sam2_like)
    with pytest.raises(CheckpointError, match=r"\(1 weights\) does not fit model vit_b: 314 "
                       r"missing .* 1 unexpected .*it looks like a SAM 2 checkpoint$"):  # fmt: skip
        _call(tmp_path, sam_run.images, sam2_like)


@pytest.mark.parametrize(
    ("option", "value", "allowed"),
    [("points_per_side", 0, "an integer in [1, 256]"),
     ("points_per_side", 2.5, "an integer in [1, 256]"),
     ("points_per_batch", 0, "an integer in [1, 4096]"),
     ("pred_iou_thresh", -0.1, "a number in [0.0, 1.0]"),
     ("stability_score_thresh", float("nan"), "a number in [0.0, 1.0]"),
     ("box_nms_thresh", True, "a number in [0.0, 1.0]"),
     ("crop_n_layers", 5, "an integer in [0, 4]"),
     ("min_mask_region_area", -1, "an integer >= 0")],
)  # fmt: skip
def test_options_out_of_range_say_what_is_allowed(option: str, value: object, allowed: str) -> None:
    with pytest.raises(MaskGenerateError) as info:
        GenerateConfig(**{option: value})  # type: ignore[arg-type]
    assert str(info.value) == f"{option}={value!r} must be {allowed}"


def test_unknown_model_lists_the_names(tmp_path: Path) -> None:
    with pytest.raises(MaskGenerateError, match="unknown model 'sam3'; known: vit_b,") as info:
        generate_masks(tmp_path, tmp_path / "out", tmp_path / "x.pth", model="sam3")
    assert all(name in str(info.value) for name in MODELS)


def test_a_missing_package_names_the_extra(
    tmp_path: Path, sam_run: Run, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(sys.modules, "segment_anything", None)  # find_spec: not installed
    with pytest.raises(MissingDependencyError, match=r"needs segment_anything: pip install "
                       r"'causalsplat\[sam\]'"):  # fmt: skip
        _call(tmp_path, sam_run.images, sam_run.checkpoint)
    monkeypatch.setitem(sys.modules, "sam2", None)
    with pytest.raises(MissingDependencyError, match=r"'causalsplat\[sam2\]'"):
        _call(tmp_path, sam_run.images, sam_run.checkpoint, model="sam2.1_hiera_t")
    monkeypatch.setitem(sys.modules, "torch", None)
    wanted = r"needs torch, segment_anything: pip install 'causalsplat\[sam,torch\]'"
    with pytest.raises(MissingDependencyError, match=wanted):
        _call(tmp_path, sam_run.images, sam_run.checkpoint)
    assert not (tmp_path / "out").exists()


def test_help_gives_the_library_defaults() -> None:
    from causalsplat.cli._masks_cmds import generate

    config = GenerateConfig()
    helps = {p.name: p.help or "" for p in generate.params}
    for name in ("points_per_side", "points_per_batch", "pred_iou_thresh",
                 "stability_score_thresh", "box_nms_thresh", "crop_n_layers",
                 "min_mask_region_area"):  # fmt: skip
        assert f"(default {getattr(config, name)})" in helps[name], name
