"""GaussianScene activations and validation; the Camera convention (OpenCV, world-to-camera)."""

from __future__ import annotations

import numpy as np
import pytest

from causalsplat.io import SH_C0, Camera, GaussianScene, InvalidSceneError


def test_camera_projects_known_points_to_known_pixels() -> None:
    # Identity pose: x right, y down, z forward.
    cam = Camera("id", 640, 480, 500.0, 400.0, 320.0, 240.0, np.eye(4))
    pts = np.array([[0, 0, 5], [1, 0, 5], [0, 1, 2], [-2, -1, 4], [0, 0, -1]], dtype=float)
    proj = cam.project(pts)
    np.testing.assert_allclose(proj.pixels[:4], [[320, 240], [420, 240], [320, 440], [70, 140]])
    np.testing.assert_allclose(proj.depth, [5, 5, 2, 4, -1])
    assert np.isnan(proj.pixels[4]).all()  # behind the camera


def test_look_at_is_opencv_with_up_pointing_up_the_image() -> None:
    cam = Camera.look_at("la", [0, -5, 0], [0, 0, 0], [0, 0, 1], 200, 100, 90)
    # Looking along +y with z up: world +x is image right, world +z is image up (smaller v).
    proj = cam.project(np.array([[0.0, 0, 0], [1, 0, 0], [0, 0, 1], [0, 5, 0]]))
    f = 50.0  # 0.5 * height / tan(45°)
    np.testing.assert_allclose(
        proj.pixels, [[100, 50], [100 + f / 5, 50], [100, 50 - f / 5], [100, 50]], atol=1e-9
    )
    np.testing.assert_allclose(proj.depth, [5, 5, 5, 10])
    np.testing.assert_allclose(cam.center, [0, -5, 0], atol=1e-12)
    np.testing.assert_allclose(cam.T_world_cam @ cam.T_cam_world, np.eye(4), atol=1e-12)
    assert cam.fx == cam.fy == pytest.approx(f)
    with pytest.raises(InvalidSceneError, match="parallel"):
        Camera.look_at("bad", [0, 0, 0], [0, 0, 1], [0, 0, 1], 10, 10, 60)


def test_camera_validation_and_scaling() -> None:
    with pytest.raises(InvalidSceneError, match="rigid"):
        Camera("s", 10, 10, 1.0, 1.0, 5.0, 5.0, np.diag([2.0, 1, 1, 1]))
    with pytest.raises(InvalidSceneError, match="intrinsics"):
        Camera("s", 10, 10, -1.0, 1.0, 5.0, 5.0, np.eye(4))
    cam = Camera("s", 1296, 968, 1170.0, 1170.0, 647.75, 483.75, np.eye(4)).scaled(320, 240)
    assert (cam.width, cam.height) == (320, 240)
    assert cam.cx == pytest.approx(647.75 * 320 / 1296)
    assert cam.fy == pytest.approx(1170.0 * 240 / 968)


def test_scene_activations() -> None:
    scene = GaussianScene(
        means=np.zeros((2, 3)),
        quats=np.array([[2.0, 0, 0, 0], [0, 0, 0, -3.0]]),
        log_scales=np.log([[1.0, 2.0, 3.0], [0.5, 0.5, 0.5]]),
        opacity_logits=np.array([0.0, -1000.0]),
        sh=np.array([[[1.0, -1.0, 10.0]], [[0.0, 0.0, 0.0]]]),
    )
    assert scene.n == 2 and scene.sh_degree == 0
    np.testing.assert_allclose(scene.opacities, [0.5, 0.0])
    np.testing.assert_allclose(scene.scales, [[1, 2, 3], [0.5, 0.5, 0.5]], rtol=1e-6)
    np.testing.assert_allclose(scene.rotations, [[1, 0, 0, 0], [0, 0, 0, -1]])
    np.testing.assert_allclose(scene.rotation_matrices[1], np.diag([-1.0, -1.0, 1.0]), atol=1e-12)
    np.testing.assert_allclose(
        scene.colors, [[0.5 + SH_C0, 0.5 - SH_C0, 1.0], [0.5] * 3], rtol=1e-6
    )


def test_scene_validation() -> None:
    ok = {
        "means": np.zeros((2, 3)),
        "quats": np.tile([1.0, 0, 0, 0], (2, 1)),
        "log_scales": np.zeros((2, 3)),
        "opacity_logits": np.zeros(2),
        "sh": np.zeros((2, 1, 3)),
    }
    for key, bad, msg in (
        ("quats", np.zeros((2, 4)), "zero quaternion"),
        ("sh", np.zeros((2, 2, 3)), "K=2"),
        ("opacity_logits", np.zeros(3), r"opacity_logits: expected shape \(2\)"),
        ("means", np.full((2, 3), np.inf), "non-finite"),
    ):
        with pytest.raises(InvalidSceneError, match=msg):
            GaussianScene(**{**ok, key: bad})


def test_from_points() -> None:
    rng = np.random.default_rng(0)
    pts, cols = rng.normal(size=(5, 3)), rng.uniform(size=(5, 3))
    for scales in (0.1, np.full(5, 0.1), np.full((5, 3), 0.1)):
        scene = GaussianScene.from_points(pts, cols, scales, opacity=0.7)
        np.testing.assert_allclose(scene.colors, cols, atol=1e-6)
        np.testing.assert_allclose(scene.scales, 0.1, rtol=1e-6)
        np.testing.assert_allclose(scene.opacities, 0.7, rtol=1e-6)
        assert scene.sh.shape == (5, 1, 3) and scene.means.dtype == np.float32
    with pytest.raises(InvalidSceneError, match="scales"):
        GaussianScene.from_points(pts, cols, 0.0)
