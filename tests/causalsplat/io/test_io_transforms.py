"""transforms.json (OpenGL camera-to-world) against COLMAP (OpenCV world-to-camera)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from causalsplat.io import (
    Camera,
    ColmapModel,
    ColmapPoints,
    TransformsFormatError,
    read_colmap_model,
    read_transforms_json,
    write_colmap_model,
    write_transforms_json,
)


def test_transforms_json_agrees_with_colmap_camera_of_the_same_pose(tmp_path: Path) -> None:
    cam = Camera.look_at(
        "images/frame_00001.png", [1.0, -4.0, 2.0], [0.2, 0.1, 0.3], [0, 0, 1], 320, 240, 55
    )
    write_colmap_model(tmp_path / "sparse", ColmapModel((cam,), (1,), ColmapPoints.empty()))
    colmap_cam = read_colmap_model(tmp_path / "sparse").cameras[0]
    # Hand-written nerfstudio file: OpenGL c2w = [right, up, back | centre].
    R = colmap_cam.R_cam_world
    c2w_gl = np.eye(4)
    c2w_gl[:3, 0], c2w_gl[:3, 1], c2w_gl[:3, 2] = R[0], -R[1], -R[2]
    c2w_gl[:3, 3] = colmap_cam.center
    doc = {
        "fl_x": cam.fx,
        "fl_y": cam.fy,
        "cx": cam.cx,
        "cy": cam.cy,
        "w": 320,
        "h": 240,
        "k1": 0.01,
        "frames": [{"file_path": cam.name, "transform_matrix": c2w_gl.tolist()}],
    }
    (tmp_path / "transforms.json").write_text(json.dumps(doc))
    (ns_cam,) = read_transforms_json(tmp_path / "transforms.json")
    np.testing.assert_allclose(ns_cam.T_cam_world, colmap_cam.T_cam_world, atol=1e-12)
    assert (ns_cam.fx, ns_cam.cx, ns_cam.width) == (colmap_cam.fx, colmap_cam.cx, 320)
    pts = np.random.default_rng(0).normal(size=(10, 3))
    np.testing.assert_allclose(
        ns_cam.project(pts).pixels, colmap_cam.project(pts).pixels, atol=1e-9
    )
    write_transforms_json(tmp_path / "again.json", (ns_cam,))
    (again,) = read_transforms_json(tmp_path / "again.json")
    np.testing.assert_allclose(again.T_cam_world, ns_cam.T_cam_world, atol=1e-12)


def test_instant_ngp_field_of_view_and_applied_transform(tmp_path: Path) -> None:
    c2w = np.eye(4)
    c2w[:3, 3] = [0, 0, 5]  # OpenGL camera at z=5 looking down -z at the origin
    applied = np.array([[0.0, 1, 0, 0], [1, 0, 0, 0], [0, 0, -1, 0]])  # nerfstudio's swap
    doc = {
        "camera_angle_x": 2 * np.arctan(0.5),
        "w": 100,
        "h": 50,
        "applied_transform": applied.tolist(),
        "frames": [{"file_path": "a.png", "transform_matrix": c2w.tolist()}],
    }
    path = tmp_path / "transforms.json"
    path.write_text(json.dumps(doc))
    (cam,) = read_transforms_json(path)
    assert cam.fx == pytest.approx(100.0) and cam.fy == pytest.approx(100.0)
    assert (cam.cx, cam.cy) == (50.0, 25.0)
    np.testing.assert_allclose(cam.project(np.array([[0.0, 0, 0]])).pixels, [[50, 25]])
    np.testing.assert_allclose(cam.project(np.array([[0.0, 0, 0]])).depth, [5.0])
    np.testing.assert_allclose(cam.project(np.array([[1.0, 0, 0]])).pixels, [[70, 25]])
    (orig,) = read_transforms_json(path, undo_applied_transform=True)
    np.testing.assert_allclose(orig.center, [0, 0, -5], atol=1e-12)


def test_bad_transforms_files(tmp_path: Path) -> None:
    path = tmp_path / "t.json"
    for doc, msg in (
        ({"w": 1, "h": 1}, "no 'frames' list"),
        ({"frames": [{}]}, r"frames\[0\] has no transform_matrix"),
        ({"frames": [{"transform_matrix": [[1, 2]]}]}, "4x4"),
        (
            {"w": 10, "h": 10, "frames": [{"transform_matrix": np.eye(4).tolist()}]},
            "no focal length",
        ),
        ({"fl_x": 10, "frames": [{"transform_matrix": np.eye(4).tolist()}]}, "'w'/'h'"),
        (
            {"fl_x": "x", "w": 1, "h": 1, "frames": [{"transform_matrix": np.eye(4).tolist()}]},
            "fl_x='x' is not a number",
        ),
    ):
        path.write_text(json.dumps(doc))
        with pytest.raises(TransformsFormatError, match=msg):
            read_transforms_json(path)
    eye = np.eye(4).tolist()
    for key, value, msg in (
        ("camera_angle_x", 0, r"camera_angle_x must be in \(0, pi\) radians, got 0"),
        ("camera_angle_y", 3.2, r"camera_angle_y must be in \(0, pi\)"),
        ("fl_x", 0, "fl_x must be > 0, got 0"),
        ("w", -4, "w must be > 0"),
    ):
        doc = {"w": 10, "h": 8, "fl_x": 5.0, "frames": [{"transform_matrix": eye}]}
        doc[key] = value
        path.write_text(json.dumps(doc))
        with pytest.raises(TransformsFormatError, match=msg):
            read_transforms_json(path)
    path.write_text("{not json")
    with pytest.raises(TransformsFormatError, match=r"t.json: cannot read JSON"):
        read_transforms_json(path)
    path.write_text('{"frames": ' * 50_000 + "[]" + "}" * 50_000)
    with pytest.raises(TransformsFormatError, match="nested too deeply"):
        read_transforms_json(path)
