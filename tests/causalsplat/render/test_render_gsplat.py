"""Optional gsplat backend: agrees with the CPU rasterizer (skipped without CUDA + gsplat)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from causalsplat.errors import MissingDependencyError
from causalsplat.io.types import Camera, GaussianScene
from causalsplat.render import build_contributors, gsplat_backend, render_rgb


def test_missing_backend_raises_with_install_hint(
    random_scene: Callable[..., GaussianScene], camera: Camera
) -> None:
    if gsplat_backend.is_available():
        pytest.skip("gsplat and CUDA are present")
    with pytest.raises(MissingDependencyError, match="pip install gsplat"):
        gsplat_backend.render_gsplat(random_scene(0), camera)


@pytest.mark.gpu
@pytest.mark.skipif(not gsplat_backend.is_available(), reason="needs CUDA and gsplat")
def test_gsplat_matches_cpu_rasterizer(random_scene: Callable[..., GaussianScene]) -> None:
    scene = random_scene(0, n=300, sh_degree=2)
    cam = Camera.look_at("g", [0.4, -3, 0.6], [0, 0, 0], [0, 0, 1], 64, 48, 50)
    rgb = gsplat_backend.render_gsplat(scene, cam)
    np.testing.assert_allclose(rgb, render_rgb(scene, cam), atol=2e-2)
    values = np.random.default_rng(0).normal(size=(scene.n, 4)).astype(np.float32)
    feats = gsplat_backend.render_gsplat(scene, cam, values)
    expected = build_contributors(scene, cam).composite(values)
    np.testing.assert_allclose(feats, expected, atol=5e-2)
