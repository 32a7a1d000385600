"""Scenes of the render benchmark: random Gaussians in a cube, and ScanNet scene0000_00."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from causalsplat.io.types import Camera, GaussianScene

SCANNET = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "scannet_scene0000_00"


@dataclass(frozen=True, slots=True)
class BenchScene:
    """A scene, its views, and a label for the report."""

    label: str
    scene: GaussianScene
    cameras: tuple[Camera, ...]


def random_scene(
    n: int = 20_000,
    *,
    seed: int = 0,
    size: int = 128,
    height: int | None = None,
    views: int = 4,
    scale_range: tuple[float, float] = (0.01, 0.05),
) -> BenchScene:
    """``n`` random anisotropic Gaussians in a unit cube (per-axis scales uniform in
    ``scale_range``), seen by ``views`` orbit cameras of ``size`` x ``height`` px (square
    by default)."""
    rng = np.random.default_rng(seed)
    scene = GaussianScene(
        means=rng.uniform(-1, 1, (n, 3)),
        quats=rng.normal(size=(n, 4)),
        log_scales=np.log(rng.uniform(*scale_range, (n, 3))),
        opacity_logits=rng.normal(size=n),
        sh=rng.normal(size=(n, 1, 3)),
    )
    height = size if height is None else height
    cams = []
    for k in range(views):
        a = 2 * np.pi * k / views
        eye = [3 * np.sin(a), -3 * np.cos(a), 0.8]
        cams.append(Camera.look_at(f"orbit{k}", eye, [0, 0, 0], [0, 0, 1], size, height, 60))
    label = f"Random scene: {n:,} Gaussians, {size}x{height}, {views} view(s)"
    return BenchScene(label, scene, tuple(cams))


def large_scene() -> BenchScene:
    """200,000 random Gaussians (scales 0.003 .. 0.015) in one 1000x750 view: about 24
    weights per pixel, as many as the ScanNet views have."""
    scene = random_scene(200_000, size=1000, height=750, views=1, scale_range=(0.003, 0.015))
    return BenchScene(scene.label.replace("Random", "Large random"), scene.scene, scene.cameras)


def scannet_scene(
    root: Path = SCANNET, *, width: int = 320, height: int = 240, views: int = 3
) -> BenchScene | None:
    """scene0000_00 as one isotropic Gaussian per vertex, with its 3 real poses; None if absent.

    Scale: 0.7 x the mean distance to the 3 nearest vertices; opacity 0.95; colour from
    the vertex. Poses: ``axis_align_matrix @ camera_to_world_unaligned`` (OpenCV).
    """
    verts_file = root / "mmdet3d_votenet_format" / "scene0000_00_vert_all.npy"
    cams_file = root / "mmdet3d_posed_images" / "cameras_scene0000_00.json"
    if not (verts_file.exists() and cams_file.exists()):
        return None
    from scipy.spatial import cKDTree

    verts = np.load(verts_file).astype(np.float64)
    dist, _ = cKDTree(verts[:, :3]).query(verts[:, :3], k=4)
    sigma = np.clip(0.7 * dist[:, 1:].mean(axis=1), 1e-3, 0.1)
    scene = GaussianScene.from_points(verts[:, :3], verts[:, 3:6] / 255.0, sigma, opacity=0.95)
    meta = json.loads(cams_file.read_text(encoding="utf-8"))
    K = np.asarray(meta["intrinsics_color_4x4"], dtype=np.float64)
    align = np.asarray(meta["axis_align_matrix"], dtype=np.float64)
    w0, h0 = meta["image_size_wh"]
    cams = []
    for frame in meta["frames"][:views]:
        c2w = align @ np.asarray(frame["camera_to_world_unaligned"], dtype=np.float64)
        cam = Camera(frame["image"], w0, h0, K[0, 0], K[1, 1], K[0, 2], K[1, 2], np.linalg.inv(c2w))
        cams.append(cam.scaled(width, height))
    label = (
        f"ScanNet scene0000_00: {scene.n:,} Gaussians, {width}x{height}, {len(cams)} real pose(s)"
    )
    return BenchScene(label, scene, tuple(cams))
