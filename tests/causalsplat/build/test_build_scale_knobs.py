"""The scale knobs of a build: image scale, threads, memory budget, progress lines."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from causalsplat.build.scale import scale_camera, scale_masks
from causalsplat.io.types import Camera
from causalsplat.masks import MaskSet
from tests.causalsplat.test_cli_store import assert_one_line_error, run


def test_a_scaled_camera_sees_every_point_at_the_scaled_pixel() -> None:
    cam = Camera.look_at("v", [0, -3, 1], [0, 0, 0.5], [0, 0, 1], 640, 480, 60)
    small = scale_camera(cam, 0.25)
    assert (small.width, small.height) == (160, 120)
    rng = np.random.default_rng(0)
    points = rng.uniform(-0.5, 0.5, (50, 3))

    def pixels(c: Camera) -> np.ndarray:
        x = (c.T_cam_world[:3, :3] @ points.T).T + c.T_cam_world[:3, 3]
        return np.stack([c.fx * x[:, 0] / x[:, 2] + c.cx, c.fy * x[:, 1] / x[:, 2] + c.cy], 1)

    np.testing.assert_allclose(pixels(small), pixels(cam) * 0.25, rtol=1e-12, atol=1e-9)
    odd = scale_camera(cam, 1 / 3)  # 213.33 x 160: rounded, ratios per axis
    assert (odd.width, odd.height) == (213, 160)
    assert odd.fx == pytest.approx(cam.fx * 213 / 640) and odd.cy == pytest.approx(cam.cy / 3)


def test_masks_are_reduced_by_area_and_never_grow() -> None:
    rng = np.random.default_rng(1)
    masks = rng.random((5, 60, 80)) < 0.4
    masks[0] = False
    masks[1] = True
    masks[2, :, :42] = True  # ten blocks and half of the eleventh
    masks[2, :, 42:] = False
    small = scale_masks(MaskSet("v", masks, labels=("a",) * 5), 20, 15)
    assert small.masks.shape == (5, 15, 20) and small.labels == ("a",) * 5
    assert not small.masks[0].any() and small.masks[1].all()
    assert small.masks[2][:, :10].all() and not small.masks[2][:, 10:].any()
    # the area rule, block by block, against a direct float64 average
    blocks = masks.reshape(5, 15, 4, 20, 4).mean(axis=(2, 4))
    assert ((blocks > 0.5) != (blocks >= 0.5)).any()  # the sample has ties
    np.testing.assert_array_equal(small.masks, blocks > 0.5)


@pytest.mark.parametrize("size", [(20, 15), (27, 20), (13, 9), (79, 59), (1, 1)])
def test_masks_sharing_no_pixel_share_none_after_the_reduction(size: tuple[int, int]) -> None:
    # A partition of the image (every pixel in exactly one mask, as exact instance masks
    # are) stays a set of disjoint masks at any scale, and nested masks stay nested.
    rng = np.random.default_rng(7)
    owner = rng.integers(0, 6, (60, 80))
    owner[:30, :40] = 6  # one large region, so that some pixels keep a majority
    parts = np.stack([owner == k for k in range(7)])
    whole = parts[6] | parts[2]
    small = scale_masks(MaskSet("v", np.concatenate([parts, whole[None]])), *size).masks
    assert small.shape == (8, size[1], size[0])
    assert small[:7].sum(axis=0).max() <= 1
    assert not (small[6] & ~small[7]).any() and not (small[2] & ~small[7]).any()
    if size == (20, 15):  # 4x4 blocks: the large region survives whole
        assert small[6][:7, :10].all()
    assert scale_masks(MaskSet("e", np.zeros((0, 60, 80), bool)), 20, 15).masks.shape == (0, 15, 20)


def test_a_half_scale_build_from_the_command_line_prints_progress_lines(
    tiny_folder: Path, tmp_path: Path
) -> None:
    config = tmp_path / "fast.json"
    config.write_text(json.dumps({"field": {"iterations": 30}}))
    db = f"sqlite:///{tmp_path / 's.db'}"
    proc = run(
        "build", str(tiny_folder), "--config", str(config), "--no-cache", "--image-scale",
        "0.5", "--threads", "1", "--memory-budget", "0", "--views", "disk", "--json",
        "--progress", db=db,
    )  # fmt: skip
    doc = json.loads(proc.stdout)
    assert doc["entities"] >= 3
    assert [s["name"] for s in doc["stages"]] == ["load", "rasterize", "field", "instances",
                                                   "graph"]  # fmt: skip
    assert all(s["seconds"] >= 0 and s["peak_rss_mib"] > 0 for s in doc["stages"])
    lines = proc.stderr.splitlines()  # not a terminal: lines, not bars
    assert "causalsplat: rasterize 12/12 (100%)" in "\n".join(lines)
    assert any(line.startswith("causalsplat: field done in ") for line in lines)
    assert not any("\r" in line for line in lines)
    quiet = run("build", str(tiny_folder), "--config", str(config), "--json", "--scene", "q",
                "--cache-dir", str(tmp_path / "c"), db=db)  # fmt: skip
    assert quiet.stderr == ""


@pytest.mark.parametrize(
    "args, message",
    [
        (["--memory-budget", "lots"], "--memory-budget 'lots': expected a size such as 12G"),
        (["--memory-budget", "-1G"], "--memory-budget '-1G': must be in [0, inf)"),
        (["--image-scale", "1.5"], "1.5 is not in the range 0<x<=1"),
        (["--threads", "0"], "0 is not in the range x>=1"),
    ],
)
def test_bad_knobs_are_one_line_errors(
    tiny_folder: Path, tmp_path: Path, args: list[str], message: str
) -> None:
    db_path = tmp_path / "none.db"
    proc = run("build", str(tiny_folder), *args, db=f"sqlite:///{db_path}", check=False)
    assert proc.returncode != 0 and message in proc.stderr, proc.stderr
    if "memory-budget" in args[0]:
        assert_one_line_error(proc, message)
    assert not db_path.exists()
