"""The feature-rendering autograd function: gradcheck, shapes, dtype, errors."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest
import torch

from causalsplat.io.types import Camera, GaussianScene
from causalsplat.render import RenderError, build_contributors, render_features


def test_gradcheck_float64_tiny_scene(random_scene: Callable[..., GaussianScene]) -> None:
    scene = random_scene(11, n=6, extent=0.5)
    cam = Camera.look_at("tiny", [0, -3, 0], [0, 0, 0], [0, 0, 1], 8, 6, 40)
    contrib = build_contributors(scene, cam)
    assert contrib.nnz > 10
    feats = torch.randn(scene.n, 3, dtype=torch.float64, requires_grad=True)
    assert torch.autograd.gradcheck(lambda f: render_features(contrib, f), (feats,))
    assert torch.autograd.gradgradcheck(lambda f: render_features(contrib, f), (feats,))


def test_image_shape_and_dtype(random_scene: Callable[..., GaussianScene], camera: Camera) -> None:
    scene = random_scene(0)
    contrib = build_contributors(scene, camera)
    for dtype in (torch.float32, torch.float64):
        feats = torch.rand(scene.n, 4, dtype=dtype)
        flat = render_features(contrib, feats)
        image = render_features(contrib, feats, as_image=True)
        assert flat.shape == (camera.height * camera.width, 4) and flat.dtype == dtype
        assert image.shape == (camera.height, camera.width, 4)
        torch.testing.assert_close(image.reshape(-1, 4), flat)
        expected = contrib.composite(feats.double().numpy()).reshape(-1, 4)
        np.testing.assert_allclose(flat.double().numpy(), expected, atol=1e-6)


def test_no_grad_input_and_wrong_shape(
    random_scene: Callable[..., GaussianScene], camera: Camera
) -> None:
    scene = random_scene(0)
    contrib = build_contributors(scene, camera)
    out = render_features(contrib, torch.rand(scene.n, 2))
    assert not out.requires_grad
    with pytest.raises(RenderError, match=r"features: expected shape \(30, C\)"):
        render_features(contrib, torch.rand(scene.n + 1, 2))
    with pytest.raises(RenderError):
        render_features(contrib, torch.rand(scene.n))
