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


def test_rows_render_the_chosen_pixels_and_their_gradient(
    random_scene: Callable[..., GaussianScene], camera: Camera, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``Contributors.rows`` (compiled and numpy) gives the full render's rows at the chosen
    pixels, in their order, and the gradient of a loss on them equals the full one's."""
    from causalsplat.render import _backend

    scene = random_scene(3)
    contrib = build_contributors(scene, camera)
    rng = np.random.default_rng(0)
    pixels = rng.choice(contrib.n_pixels, 40, replace=False)  # unsorted on purpose
    feats = torch.rand(scene.n, 3, dtype=torch.float64, requires_grad=True)
    full = render_features(contrib, feats)
    (full[torch.from_numpy(pixels)] ** 2).sum().backward()
    assert feats.grad is not None
    want = feats.grad.clone()
    parts = []
    for compiled in (True, False):
        monkeypatch.setattr(_backend, "numba_available", lambda c=compiled: c)
        sub = contrib.rows(pixels)
        assert (sub.width, sub.height, sub.n_gaussians) == (40, 1, scene.n)
        parts.append((sub.indptr, sub.indices, sub.weights))
        feats.grad = None
        out = render_features(sub, feats)
        torch.testing.assert_close(out, full[torch.from_numpy(pixels)].detach())
        (out**2).sum().backward()
        torch.testing.assert_close(feats.grad, want)
    for a, b in zip(*parts, strict=True):
        np.testing.assert_array_equal(a, b)
    assert contrib.rows(np.zeros(0, dtype=np.int64)).nnz == 0
    with pytest.raises(RenderError, match=rf"flat indices in \[0, {contrib.n_pixels}\)"):
        contrib.rows(np.array([contrib.n_pixels]))


@pytest.mark.parametrize("compiled", [True, False])
def test_transposed_rows_into_a_reused_buffer(
    random_scene: Callable[..., GaussianScene],
    camera: Camera,
    monkeypatch: pytest.MonkeyPatch,
    compiled: bool,
) -> None:
    """``out=`` is overwritten with the product (old contents do not leak into it) and a
    buffer of the wrong shape, dtype or layout is refused."""
    from causalsplat.render import _backend

    monkeypatch.setattr(_backend, "numba_available", lambda: compiled)
    contrib = build_contributors(random_scene(4), camera)
    rng = np.random.default_rng(2)
    buffer = np.full((contrib.n_gaussians, 3), 7.0)
    for _ in range(2):
        pixels = np.sort(rng.choice(contrib.n_pixels, 30, replace=False))
        grad = rng.standard_normal((30, 3))
        want = contrib.rows(pixels).matrix(np.float64).T @ grad
        got = contrib.transposed_rows(pixels, grad, out=buffer)
        assert got is buffer
        np.testing.assert_allclose(buffer, want, rtol=1e-12, atol=1e-12)
    for bad in (np.zeros((contrib.n_gaussians, 2)), np.zeros((contrib.n_gaussians, 3), np.float32),
                np.zeros((3, contrib.n_gaussians)).T):  # fmt: skip
        with pytest.raises(RenderError, match="out must be a C-contiguous float64 array"):
            contrib.transposed_rows(pixels, grad, out=bad)


@pytest.mark.parametrize("compiled", [True, False])
def test_render_at_pixels_matches_the_full_render_and_passes_gradcheck(
    random_scene: Callable[..., GaussianScene],
    camera: Camera,
    monkeypatch: pytest.MonkeyPatch,
    compiled: bool,
) -> None:
    from causalsplat.render import _autograd

    monkeypatch.setattr(_autograd, "numba_available", lambda: compiled)
    scene = random_scene(4)
    contrib = build_contributors(scene, camera)
    pixels = np.random.default_rng(1).choice(contrib.n_pixels, 30, replace=False)
    for dtype in (torch.float32, torch.float64):
        feats = torch.rand(scene.n, 3, dtype=dtype, requires_grad=True)
        out = render_features(contrib, feats, pixels=pixels)
        assert out.shape == (30, 3) and out.dtype == dtype
        full = render_features(contrib, feats)[torch.from_numpy(pixels)]
        torch.testing.assert_close(out, full)
        (g_rows,) = torch.autograd.grad((out * out).sum(), feats)
        (g_full,) = torch.autograd.grad((full * full).sum(), feats)
        torch.testing.assert_close(g_rows, g_full)
    small = random_scene(11, n=6, extent=0.5)
    cam = Camera.look_at("tiny", [0, -3, 0], [0, 0, 0], [0, 0, 1], 8, 6, 40)
    c = build_contributors(small, cam)
    px = np.array([20, 3, 27, 28, 19])
    assert c.rows(px).nnz > 5
    f64 = torch.randn(small.n, 2, dtype=torch.float64, requires_grad=True)
    assert torch.autograd.gradcheck(lambda f: render_features(c, f, pixels=px), (f64,))
    assert torch.autograd.gradgradcheck(lambda f: render_features(c, f, pixels=px), (f64,))
    with pytest.raises(
        RenderError, match=r"pixels must be a 1-D array of flat indices in \[0, 48\)"
    ):
        render_features(c, f64, pixels=np.array([48]))
    with pytest.raises(RenderError, match="exclude each other"):
        render_features(c, f64, pixels=px, as_image=True)


def test_alpha_compiled_and_numpy_are_the_row_sums(
    random_scene: Callable[..., GaussianScene], camera: Camera, monkeypatch: pytest.MonkeyPatch
) -> None:
    from causalsplat.render import _backend

    contrib = build_contributors(random_scene(6), camera)
    want = contrib.matrix(np.float64).sum(axis=1).A.ravel().reshape(camera.height, camera.width)
    compiled = contrib.alpha()
    monkeypatch.setattr(_backend, "numba_available", lambda: False)
    np.testing.assert_allclose(compiled, want, rtol=1e-12, atol=0)
    np.testing.assert_allclose(contrib.alpha(), compiled, rtol=1e-15, atol=0)
    assert compiled.max() > 0.5
