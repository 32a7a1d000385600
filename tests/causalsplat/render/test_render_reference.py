"""Both fast paths (the compiled numba kernel and the numpy path) against the float64
per-pixel reference: weights, RGB, depth, ids, features.

Tolerances: the fast paths project in float64 and store weights as float32, so weights
agree to 1e-6 absolute (float32 rounding of values <= 1), renders to 1e-5 and feature
gradients to 1e-5 relative to their scale.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np
import pytest
import torch
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from causalsplat.io.types import Camera, GaussianScene
from causalsplat.render import (
    RasterConfig,
    build_contributors,
    render_depth,
    render_features,
    render_ids,
    render_rgb,
)
from causalsplat.render._reference import (
    reference_depth,
    reference_ids,
    reference_rgb,
    reference_weights,
)
from tests.conftest import shared_data_path

WEIGHT_TOL = 1e-6
RENDER_TOL = 1e-5

CONFIGS = [
    RasterConfig(),
    RasterConfig(max_contributors=3),
    RasterConfig(transmittance_min=0.2),
    RasterConfig(tile_size=5, chunk=7),
    RasterConfig(low_pass=0.0, alpha_max=0.5, alpha_min=0.05),
]
CONFIG_IDS = ["default", "cap3", "tmin0.2", "tile5-chunk7", "no-lowpass"]


BACKENDS = ("numba", "numpy")


def check_against_reference(scene: GaussianScene, camera: Camera, config: RasterConfig) -> None:
    """Hold every backend to the reference (computed once) with ``config``'s other knobs."""
    ref = reference_weights(scene, camera, config)
    for backend in BACKENDS:
        check_backend(scene, camera, dataclasses.replace(config, backend=backend), ref)


def check_backend(
    scene: GaussianScene, camera: Camera, config: RasterConfig, ref: np.ndarray
) -> None:
    contrib = build_contributors(scene, camera, config=config, cache=False)
    fast = contrib.matrix().toarray()
    np.testing.assert_allclose(fast, ref, rtol=0, atol=WEIGHT_TOL)
    # The same (pixel, Gaussian) pairs are kept (no pair dropped or added).
    np.testing.assert_array_equal(fast > 0, ref > 0)
    np.testing.assert_allclose(
        render_rgb(scene, camera, config=config),
        reference_rgb(scene, camera, ref),
        rtol=0,
        atol=RENDER_TOL,
    )
    depth_ref = reference_depth(scene, camera, ref)
    np.testing.assert_allclose(
        render_depth(scene, camera, config=config),
        depth_ref,
        rtol=RENDER_TOL,
        atol=RENDER_TOL,
    )
    ids = np.random.default_rng(7).integers(-1, 4, scene.n)
    shape = (camera.height, camera.width)
    np.testing.assert_array_equal(
        render_ids(scene, camera, ids, config=config, min_alpha=0.3),
        reference_ids(ref, ids, shape, min_alpha=0.3),
    )
    feats = torch.randn(scene.n, 5, dtype=torch.float32, generator=torch.Generator().manual_seed(1))
    feats.requires_grad_(True)
    out = render_features(contrib, feats)
    grad_out = torch.randn(out.shape, generator=torch.Generator().manual_seed(2))
    out.backward(grad_out)
    f64, g64 = feats.detach().double().numpy(), grad_out.double().numpy()
    np.testing.assert_allclose(out.detach().numpy(), ref @ f64, rtol=0, atol=RENDER_TOL * 5)
    grad_ref = ref.T @ g64
    scale = max(1.0, float(np.abs(grad_ref).max()))
    np.testing.assert_allclose(feats.grad.numpy(), grad_ref, rtol=0, atol=RENDER_TOL * scale)


@pytest.mark.parametrize("config", CONFIGS, ids=CONFIG_IDS)
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_fast_path_matches_reference_on_random_scenes(
    random_scene: Callable[..., GaussianScene], camera: Camera, seed: int, config: RasterConfig
) -> None:
    scene = random_scene(seed, n=30, sh_degree=seed)
    weights = reference_weights(scene, camera, config)
    assert (weights > 0).sum() > 50  # the view really sees the scene
    check_against_reference(scene, camera, config)


@settings(
    max_examples=20, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    seed=st.integers(0, 2**31 - 1),
    cap=st.one_of(st.none(), st.integers(1, 6)),
    tmin=st.sampled_from([0.0, 1e-4, 0.05, 0.5]),
    tile=st.integers(1, 20),
    chunk=st.integers(1, 40),
)
def test_fast_path_matches_reference_for_random_configs(
    random_scene: Callable[..., GaussianScene],
    seed: int,
    cap: int | None,
    tmin: float,
    tile: int,
    chunk: int,
) -> None:
    scene = random_scene(seed, n=15, sh_degree=seed % 4)
    cam = Camera.look_at("h", [0.2, -2.5, 0.4], [0, 0, 0], [0, 0, 1], 12, 10, 55)
    cfg = RasterConfig(max_contributors=cap, transmittance_min=tmin, tile_size=tile, chunk=chunk)
    check_against_reference(scene, cam, cfg)


def test_many_overlapping_gaussians_hit_transmittance_and_cap(
    random_scene: Callable[..., GaussianScene], camera: Camera
) -> None:
    scene = random_scene(5, n=80, extent=0.4, scale_range=(0.2, 0.6), logit_std=0.5)
    config = RasterConfig()
    weights = reference_weights(scene, camera, config)
    # Early termination is exercised: many pixels end with transmittance below 1e-3.
    assert (weights.sum(axis=1) > 0.999).sum() > 20
    check_against_reference(scene, camera, config)
    check_against_reference(scene, camera, RasterConfig(max_contributors=5))


def test_render_of_uniform_feature_equals_alpha(
    random_scene: Callable[..., GaussianScene], camera: Camera
) -> None:
    scene = random_scene(3)
    contrib = build_contributors(scene, camera)
    ones = torch.ones(scene.n, 1, dtype=torch.float64)
    alpha = render_features(contrib, ones, as_image=True)[..., 0].numpy()
    np.testing.assert_allclose(alpha, contrib.alpha(), atol=1e-12)
    assert alpha.max() <= 1.0 and alpha.min() >= 0.0


def _ply_crop() -> tuple[GaussianScene, Camera]:
    from causalsplat.io import read_ply

    scene = read_ply(shared_data_path("inria_3dgs_ply_sample", "point_cloud_iter7000.ply"))
    center = np.median(scene.means.astype(np.float64), axis=0)
    dist = np.linalg.norm(scene.means - center, axis=1)
    crop = scene.subset(np.argsort(dist)[:250])
    radius = float(np.sort(dist)[249])
    cam = Camera.look_at(
        "ply", center + np.array([0.0, -2.5 * radius, 0.5 * radius]), center, [0, 0, 1], 32, 24, 55
    )
    return crop, cam


@pytest.mark.shared_data
def test_fast_path_matches_reference_on_real_ply_crop() -> None:
    scene, cam = _ply_crop()
    assert scene.sh_degree == 3
    weights = reference_weights(scene, cam, RasterConfig())
    assert (weights.sum(axis=1) > 0.05).mean() > 0.5  # most pixels see the crop
    check_against_reference(scene, cam, RasterConfig())
    check_against_reference(scene, cam, RasterConfig(max_contributors=4))
