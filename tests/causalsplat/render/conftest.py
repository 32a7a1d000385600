"""Scene and camera factories for the rasterizer tests."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from causalsplat.io.types import Camera, GaussianScene


def make_random_scene(
    seed: int,
    n: int = 30,
    *,
    extent: float = 1.0,
    scale_range: tuple[float, float] = (0.05, 0.4),
    logit_std: float = 2.0,
    sh_degree: int = 1,
) -> GaussianScene:
    """Random anisotropic Gaussians in a cube of half-size ``extent`` around the origin."""
    rng = np.random.default_rng(seed)
    k = (sh_degree + 1) ** 2
    return GaussianScene(
        means=rng.uniform(-extent, extent, (n, 3)),
        quats=rng.normal(size=(n, 4)),
        log_scales=np.log(rng.uniform(*scale_range, (n, 3))),
        opacity_logits=rng.normal(size=n) * logit_std,
        sh=rng.normal(size=(n, k, 3)) * 0.5,
    )


def make_camera(width: int = 24, height: int = 20, distance: float = 3.0) -> Camera:
    return Camera.look_at("cam", [0.4, -distance, 0.6], [0, 0, 0], [0, 0, 1], width, height, 50)


@pytest.fixture
def random_scene() -> Callable[..., GaussianScene]:
    return make_random_scene


@pytest.fixture
def camera() -> Camera:
    return make_camera()
