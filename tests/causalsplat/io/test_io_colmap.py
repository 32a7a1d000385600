"""COLMAP sparse models: text and binary agree, a known pose projects correctly, bad files."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest

from causalsplat.io import (
    Camera,
    ColmapFormatError,
    ColmapModel,
    ColmapPoints,
    read_colmap_model,
    write_colmap_model,
)


def _model() -> ColmapModel:
    rng = np.random.default_rng(0)
    cams = []
    for k in range(4):
        eye = rng.normal(size=3) * 4 + np.array([0, 0, 2])
        cam = Camera.look_at(
            f"img_{k:03d}.jpg",
            eye,
            rng.normal(size=3) * 0.3,
            [0, 0, 1],
            640 + 8 * k,
            480,
            40 + 5 * k,
        )
        cams.append(
            Camera(
                cam.name,
                cam.width,
                cam.height,
                cam.fx,
                cam.fy * 1.01,
                cam.cx + 0.25,
                cam.cy - 0.5,
                cam.T_cam_world,
            )
        )
    points = ColmapPoints(
        ids=np.arange(1, 51, dtype=np.int64) * 7,
        xyz=rng.normal(size=(50, 3)),
        rgb=rng.integers(0, 256, (50, 3)).astype(np.uint8),
        error=rng.uniform(0, 2, 50),
    )
    return ColmapModel(cameras=tuple(cams), image_ids=(3, 5, 8, 13), points=points)


def _assert_same_cameras(a: tuple[Camera, ...], b: tuple[Camera, ...], atol: float) -> None:
    assert len(a) == len(b)
    for ca, cb in zip(a, b):
        assert (ca.name, ca.width, ca.height) == (cb.name, cb.width, cb.height)
        np.testing.assert_allclose([ca.fx, ca.fy, ca.cx, ca.cy], [cb.fx, cb.fy, cb.cx, cb.cy])
        np.testing.assert_allclose(ca.T_cam_world, cb.T_cam_world, atol=atol)


def test_text_and_binary_readers_agree(tmp_path: Path) -> None:
    model = _model()
    write_colmap_model(tmp_path / "txt", model, binary=False)
    write_colmap_model(tmp_path / "bin", model, binary=True)
    assert sorted(p.name for p in (tmp_path / "bin").iterdir()) == [
        "cameras.bin",
        "images.bin",
        "points3D.bin",
    ]
    text = read_colmap_model(tmp_path / "txt")
    binary = read_colmap_model(tmp_path / "bin")
    _assert_same_cameras(text.cameras, binary.cameras, atol=0)
    assert text.image_ids == binary.image_ids == model.image_ids
    _assert_same_cameras(text.cameras, model.cameras, atol=1e-12)
    for name in ("ids", "xyz", "rgb", "error"):
        np.testing.assert_array_equal(getattr(text.points, name), getattr(binary.points, name))
        np.testing.assert_array_equal(getattr(text.points, name), getattr(model.points, name))


def test_known_pose_projects_known_points(tmp_path: Path) -> None:
    # Camera rotated 90° about world z (q = (cos45°, 0, 0, sin45°)), translated by t.
    s = np.sqrt(0.5)
    (tmp_path / "cameras.txt").write_text(
        "# comment\n1 PINHOLE 100 80 50 60 40 30\n2 SIMPLE_RADIAL 100 80 70 50 40 0.1\n"
    )
    (tmp_path / "images.txt").write_text(
        f"# header\n1 {s} 0 0 {s} 1 2 3 1 a b.png\n10 20 -1\n2 1 0 0 0 0 0 0 2 c.png\n\n"
    )
    model = read_colmap_model(tmp_path, allow_distortion=True)
    assert model.distorted == ("camera 2 (SIMPLE_RADIAL, largest coefficient 0.1)",)
    assert [c.name for c in model.cameras] == ["a b.png", "c.png"]
    cam = model.cameras[0]
    # x_cam = R x_world + t with R = rot_z(90°): (x, y, z) -> (-y, x, z).
    world = np.array([[2.0, 1.0, 2.0]])
    x_cam = np.array([-1.0 + 1, 2.0 + 2, 2.0 + 3])
    np.testing.assert_allclose(cam.world_to_camera(world)[0], x_cam, atol=1e-12)
    np.testing.assert_allclose(
        cam.project(world).pixels[0], [50 * 0 / 5 + 40, 60 * 4 / 5 + 30], atol=1e-12
    )
    radial = model.cameras[1]  # distortion k dropped: a pinhole camera with f = 70
    assert (radial.fx, radial.fy, radial.cx, radial.cy) == (70, 70, 50, 40)
    assert model.points.ids.shape == (0,)


def test_unsupported_model_and_missing_camera(tmp_path: Path) -> None:
    (tmp_path / "cameras.txt").write_text("1 OPENCV_FISHEYE 10 10 5 5 5 5 0 0 0 0\n")
    (tmp_path / "images.txt").write_text("1 1 0 0 0 0 0 0 1 a.png\n\n")
    with pytest.raises(ColmapFormatError, match="OPENCV_FISHEYE"):
        read_colmap_model(tmp_path)
    (tmp_path / "images.txt").write_text("1 1 0 0 0 0 0 0 9 a.png\n\n")
    with pytest.raises(ColmapFormatError, match="missing camera 9"):
        read_colmap_model(tmp_path)
    (tmp_path / "cameras.txt").write_text("1 PINHOLE 10 10 5 5\n")
    with pytest.raises(ColmapFormatError, match=r"cameras.txt:1: .*PINHOLE needs 4"):
        read_colmap_model(tmp_path)
    with pytest.raises(ColmapFormatError, match=r"no cameras.bin or cameras.txt"):
        read_colmap_model(tmp_path / "nowhere")


def test_corrupt_binary_files_raise_typed_errors(tmp_path: Path) -> None:
    write_colmap_model(tmp_path, _model(), binary=True)
    images = (tmp_path / "images.bin").read_bytes()
    (tmp_path / "images.bin").write_bytes(images[:-20])
    with pytest.raises(ColmapFormatError, match=r"images.bin: (truncated|unterminated)"):
        read_colmap_model(tmp_path)
    (tmp_path / "images.bin").write_bytes(images + b"\x00")
    with pytest.raises(ColmapFormatError, match=r"images.bin: 1 unexpected trailing"):
        read_colmap_model(tmp_path)
    (tmp_path / "images.bin").write_bytes(images)
    cameras = (tmp_path / "cameras.bin").read_bytes()
    (tmp_path / "cameras.bin").write_bytes(struct.pack("<Q", 10**12) + cameras[8:])
    with pytest.raises(ColmapFormatError, match=r"cameras.bin: implausible number of cameras"):
        read_colmap_model(tmp_path)
    bad_model = cameras[:12] + struct.pack("<i", 99) + cameras[16:]
    (tmp_path / "cameras.bin").write_bytes(bad_model)
    with pytest.raises(ColmapFormatError, match=r"cameras.bin: camera 1 has unknown model id 99"):
        read_colmap_model(tmp_path)
    (tmp_path / "cameras.bin").write_bytes(cameras)
    points = (tmp_path / "points3D.bin").read_bytes()
    (tmp_path / "points3D.bin").write_bytes(points[: len(points) // 2])
    with pytest.raises(ColmapFormatError, match=r"points3D.bin: truncated"):
        read_colmap_model(tmp_path)


def test_images_without_their_empty_points_lines(tmp_path: Path) -> None:
    """Some writers leave out the empty POINTS2D line of an image: every camera is kept."""
    (tmp_path / "cameras.txt").write_text("1 PINHOLE 100 80 50 60 40 30\n")
    (tmp_path / "images.txt").write_text(
        "1 1 0 0 0 0 0 0 1 a.png\n2 1 0 0 0 0 0 1 1 b.png\n10 20 -1 11.5 2 7\n"
        "3 1 0 0 0 0 0 2 1 c.png\n"
    )
    model = read_colmap_model(tmp_path)
    assert [c.name for c in model.cameras] == ["a.png", "b.png", "c.png"]
    assert model.image_ids == (1, 2, 3)
