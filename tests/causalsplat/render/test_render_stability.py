"""Numerical stability (DESIGN §12): stiff and extreme inputs give finite outputs that match
the float64 reference, or a typed error.

Tolerance: weights within 1e-6 absolute and renders within 1e-5 of the reference, the
same as the regular reference tests (see test_render_reference.py).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest
import torch

from causalsplat.io.errors import InvalidSceneError
from causalsplat.io.types import Camera, GaussianScene
from causalsplat.render import (
    RasterConfig,
    RenderError,
    build_contributors,
    render_alpha,
    render_depth,
    render_features,
    render_ids,
    render_rgb,
)
from causalsplat.render._reference import reference_weights
from tests.causalsplat.render.test_render_reference import check_against_reference


def _scene(means: np.ndarray, log_scales: np.ndarray, **kw: np.ndarray) -> GaussianScene:
    n = means.shape[0]
    rng = np.random.default_rng(0)
    return GaussianScene(
        means=means,
        quats=kw.get("quats", rng.normal(size=(n, 4))),
        log_scales=log_scales,
        opacity_logits=kw.get("opacity_logits", np.full(n, 1.0)),
        sh=kw.get("sh", rng.normal(size=(n, 1, 3))),
    )


def _all_finite(scene: GaussianScene, cam: Camera) -> None:
    for out in (render_rgb(scene, cam), render_depth(scene, cam), render_alpha(scene, cam)):
        assert np.all(np.isfinite(out))
    contrib = build_contributors(scene, cam)
    assert np.all(np.isfinite(contrib.weights)) and np.all(contrib.weights >= 0)
    assert contrib.alpha().max() <= 1.0 + 1e-6


def test_near_singular_and_extremely_anisotropic_covariances(camera: Camera) -> None:
    rng = np.random.default_rng(1)
    n = 20
    log_scales = np.log(np.tile([0.3, 0.3, 1e-7], (n, 1)))  # flat discs: singular in 3D
    log_scales[::2] = np.log([0.5, 5e-7, 5e-7])  # needles, 1e6:1
    scene = _scene(rng.uniform(-1, 1, (n, 3)), log_scales)
    _all_finite(scene, camera)
    check_against_reference(scene, camera, RasterConfig())


@pytest.mark.parametrize("scale", [1e-6, 1e-3, 1.0, 1e2, 1e4])
def test_scales_from_1e_minus_6_to_1e4(camera: Camera, scale: float) -> None:
    rng = np.random.default_rng(2)
    n = 12
    log_scales = np.log(scale * rng.uniform(0.5, 2.0, (n, 3)))
    scene = _scene(rng.uniform(-1, 1, (n, 3)), log_scales, opacity_logits=np.full(n, -1.0))
    _all_finite(scene, camera)
    check_against_reference(scene, camera, RasterConfig())


def test_coordinates_offset_by_1e6(random_scene: Callable[..., GaussianScene]) -> None:
    base = random_scene(4, n=25, extent=4.0, scale_range=(0.3, 1.0))
    offset = np.array([1e6, -1e6, 1e6])
    # Means on the float32 grid at 1e6 (spacing 1/16), so both scenes hold the same geometry.
    local = np.round(base.means.astype(np.float64) * 16) / 16
    far = GaussianScene(local + offset, base.quats, base.log_scales, base.opacity_logits, base.sh)
    near = GaussianScene(local, base.quats, base.log_scales, base.opacity_logits, base.sh)
    np.testing.assert_array_equal(far.means.astype(np.float64) - offset, local)
    eye, up = np.array([1.0, -12.0, 2.0]), [0, 0, 1]
    cam_far = Camera.look_at("far", eye + offset, offset, up, 24, 20, 50)
    cam_near = Camera.look_at("near", eye, np.zeros(3), up, 24, 20, 50)
    _all_finite(far, cam_far)
    check_against_reference(far, cam_far, RasterConfig())
    w_far = build_contributors(far, cam_far).matrix().toarray()
    w_near = build_contributors(near, cam_near).matrix().toarray()
    assert (w_near > 0).sum() > 100
    np.testing.assert_allclose(w_far, w_near, atol=1e-6)


def test_zero_quaternion_is_a_typed_error_and_norm_does_not_matter(camera: Camera) -> None:
    rng = np.random.default_rng(3)
    n = 10
    quats = rng.normal(size=(n, 4))
    means, log_scales = rng.uniform(-1, 1, (n, 3)), np.log(rng.uniform(0.1, 0.4, (n, 3)))
    bad = quats.copy()
    bad[4] = 0.0
    with pytest.raises(InvalidSceneError, match=r"zero quaternion.*Gaussian 4"):
        _scene(means, log_scales, quats=bad)
    unit = _scene(means, log_scales, quats=quats / np.linalg.norm(quats, axis=1, keepdims=True))
    for factor in (1e-3, 7.0, 1e3):
        scaled = _scene(means, log_scales, quats=quats * factor)
        np.testing.assert_allclose(
            build_contributors(scaled, camera).matrix().toarray(),
            build_contributors(unit, camera).matrix().toarray(),
            atol=1e-6,
        )


def test_opacity_logits_of_plus_minus_50(camera: Camera) -> None:
    rng = np.random.default_rng(5)
    n = 16
    logits = np.where(np.arange(n) % 2 == 0, 50.0, -50.0)
    scene = _scene(
        rng.uniform(-1, 1, (n, 3)), np.log(rng.uniform(0.1, 0.4, (n, 3))), opacity_logits=logits
    )
    _all_finite(scene, camera)
    check_against_reference(scene, camera, RasterConfig())
    contrib = build_contributors(scene, camera)
    assert set(np.unique(contrib.indices).tolist()) <= set(range(0, n, 2))  # -50 never drawn
    assert 0.95 < contrib.weights.max() <= 0.99 + 1e-7  # opaque, but alpha clamped at 0.99


def test_gaussians_behind_at_and_just_in_front_of_the_camera() -> None:
    cam = Camera.look_at("c", [0, 0, 0], [0, 1, 0], [0, 0, 1], 20, 16, 60)
    # Camera looks along +y; camera-frame depth of a point is its world y.
    ys = [-1.0, -1e-9, 0.0, 0.005, 0.01, 0.02, 0.5, 1.0]
    means = np.array([[0.01 * i, y, 0.0] for i, y in enumerate(ys)])
    scene = _scene(means, np.log(np.full((len(ys), 3), 0.05)))
    _all_finite(scene, cam)
    check_against_reference(scene, cam, RasterConfig())
    drawn = set(np.unique(build_contributors(scene, cam).indices).tolist())
    assert drawn.isdisjoint({0, 1, 2, 3})  # behind, at, or before the near plane 0.01
    assert {4, 5, 6, 7} & drawn


def test_off_screen_gaussians_near_the_camera_are_stable() -> None:
    cam = Camera.look_at("c", [0, 0, 0], [0, 1, 0], [0, 0, 1], 20, 16, 60)
    # Large x/z: the Jacobian clamp keeps these from exploding into the image.
    means = np.array([[5.0, 0.02, 0.0], [-50.0, 0.05, 1.0], [0.0, 0.03, 80.0], [0.0, 2.0, 0.0]])
    scene = _scene(means, np.log(np.full((4, 3), 0.5)))
    _all_finite(scene, cam)
    check_against_reference(scene, cam, RasterConfig())


def test_view_that_sees_nothing(random_scene: Callable[..., GaussianScene]) -> None:
    scene = random_scene(0)
    away = Camera.look_at("away", [0, -3, 0], [0, -6, 0], [0, 0, 1], 16, 12, 50)
    contrib = build_contributors(scene, away)
    assert contrib.nnz == 0 and contrib.indptr.shape == (16 * 12 + 1,)
    assert not reference_weights(scene, away).any()
    assert not render_rgb(scene, away).any() and not render_depth(scene, away).any()
    ids = render_ids(scene, away, np.arange(scene.n))
    assert ids.shape == (12, 16) and (ids == -1).all()
    feats = torch.rand(scene.n, 3, requires_grad=True)
    out = render_features(contrib, feats)
    out.sum().backward()
    assert not out.any() and not feats.grad.any()


def test_empty_scene(camera: Camera) -> None:
    scene = _scene(
        np.zeros((0, 3)),
        np.zeros((0, 3)),
        quats=np.zeros((0, 4)),
        opacity_logits=np.zeros(0),
        sh=np.zeros((0, 1, 3)),
    )
    assert render_rgb(scene, camera).shape == (camera.height, camera.width, 3)
    assert not render_rgb(scene, camera).any()
    assert (render_ids(scene, camera, np.zeros(0, np.int64)) == -1).all()


def test_overflowing_scale_is_a_typed_error(camera: Camera) -> None:
    scene = _scene(np.zeros((2, 3)), np.array([[0.0, 0.0, 0.0], [400.0, 0.0, 0.0]]))
    with pytest.raises(RenderError, match="Gaussian 1"):
        build_contributors(scene, camera)


def test_non_finite_inputs_are_typed_errors() -> None:
    good = np.zeros((2, 3))
    for field, value in (
        ("means", np.array([[0, 0, np.nan], [0, 0, 0]])),
        ("log_scales", np.array([[np.inf, 0, 0], [0, 0, 0]])),
    ):
        kwargs = {"means": good, "log_scales": good, field: value}
        with pytest.raises(InvalidSceneError, match=field):
            _scene(kwargs["means"], kwargs["log_scales"])
