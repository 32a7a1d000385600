"""A scene in other units, or away from the origin, builds the graph it builds in metres at
the origin; positions that float32 can no longer hold are refused in one line."""

from __future__ import annotations

import dataclasses
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from causalsplat.build import BuildConfig, build_scene
from causalsplat.build.coverage import NEAR_SHARE, median_depth, scene_near
from causalsplat.instances import instance_quality
from causalsplat.io import read_gaussian_ply, write_ply
from causalsplat.io.colmap import read_colmap_model, write_colmap_model
from tests.conftest import COMMAND_TIMEOUT_S, REPO_ROOT

#: Few steps: the test compares builds of one scene with itself.
FAST = BuildConfig.from_json({"field": {"iterations": 60}})


def moved(src: Path, dst: Path, scale: float, offset: float) -> Path:
    """The scene folder ``src`` with its world scaled by ``scale`` and then shifted by
    ``offset`` along every axis: Gaussian centres and sizes, and the camera poses."""
    shutil.copytree(src, dst)
    ply = next(dst.glob("*.ply"))
    g = read_gaussian_ply(ply)
    means = (g.scene.means.astype(np.float64) * scale + offset).astype(np.float32)
    log_scales = g.scene.log_scales + np.float32(np.log(scale))
    write_ply(ply, dataclasses.replace(g.scene, means=means, log_scales=log_scales),
              extra=g.extra, layout=g.layout)  # fmt: skip
    sparse = next(p.parent for p in dst.rglob("cameras.txt"))
    model = read_colmap_model(sparse)
    cameras = []
    for cam in model.cameras:
        T = cam.T_cam_world.copy()
        # x_cam = R x + t; with x' = s x + o: x_cam' = s x_cam = R x' + (s t - R o)
        T[:3, 3] = scale * T[:3, 3] - T[:3, :3] @ np.full(3, offset)
        cameras.append(dataclasses.replace(cam, T_cam_world=T))
    for f in sparse.iterdir():
        f.unlink()
    write_colmap_model(sparse, dataclasses.replace(model, cameras=tuple(cameras)))
    return dst


@pytest.fixture(scope="module")
def reference(tiny_folder: Path) -> np.ndarray:
    return build_scene(tiny_folder, config=FAST, cache_dir=False).gaussian_labels


@pytest.mark.parametrize(("scale", "offset"), [(1e-3, 0.0), (1e3, 0.0), (1.0, 1e4)])
def test_other_units_and_offsets_build_the_same_entities(
    tiny_folder: Path, tmp_path: Path, reference: np.ndarray, scale: float, offset: float
) -> None:
    folder = moved(tiny_folder, tmp_path / "moved", scale, offset)
    built = build_scene(folder, config=FAST, cache_dir=False)
    q = instance_quality(built.gaussian_labels, reference)
    assert built.graph.entities and q.n_pred == q.n_gt
    assert q.mean_best_iou > 0.9, q.mean_best_iou
    lowered = [w for w in built.warnings if w.startswith("raster.near lowered")]
    assert bool(lowered) == (scale < 1)


def test_the_near_plane_follows_the_scene_only_below_its_default(tiny_folder: Path) -> None:
    from causalsplat.build.folder import read_scene_folder

    folder = read_scene_folder(tiny_folder)
    depth = median_depth(folder.gaussians.means, folder.cameras)
    assert depth is not None and NEAR_SHARE * depth > 0.01  # a room keeps the default
    assert scene_near(0.01, depth) == 0.01
    assert scene_near(0.01, depth * 1e-3) == pytest.approx(NEAR_SHARE * depth * 1e-3)
    assert scene_near(0.01, None) == scene_near(0.01, float("nan")) == 0.01


def test_positions_float32_cannot_hold_are_one_line(tiny_folder: Path, tmp_path: Path) -> None:
    folder = moved(tiny_folder, tmp_path / "far", 1.0, 1e7)
    db = tmp_path / "far.db"
    proc = subprocess.run(
        [sys.executable, "-m", "causalsplat", "build", str(folder), "--no-cache",
         "--db", str(db)],
        capture_output=True, text=True, cwd=REPO_ROOT, timeout=COMMAND_TIMEOUT_S,
    )  # fmt: skip
    assert proc.returncode == 1
    (line,) = proc.stderr.strip().splitlines()
    assert "float32 positions reach 1e+07 units from the origin" in line
    assert "recentre the scene" in line and not db.exists()
