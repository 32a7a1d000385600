"""The render benchmark's baseline is a faithful composite, and the quick run works."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest
import torch

from causalsplat.bench._render_dense import DenseTileCompositor
from causalsplat.io.types import Camera, GaussianScene
from causalsplat.render import RasterConfig, build_contributors, render_features


def test_dense_baseline_matches_cached_weights(
    random_scene: Callable[..., GaussianScene], camera: Camera
) -> None:
    scene = random_scene(5, n=80, extent=0.4, scale_range=(0.2, 0.6), logit_std=0.5)
    dense = DenseTileCompositor(scene, camera, RasterConfig(tile_size=8))
    feats = torch.randn(scene.n, 3, dtype=torch.float64, requires_grad=True)
    grad = torch.randn(camera.width * camera.height, 3, dtype=torch.float64)
    out = dense(feats)
    out.backward(grad)
    dense_grad = feats.grad.clone()
    feats.grad = None
    fast = render_features(build_contributors(scene, camera), feats)
    fast.backward(grad)
    # The baseline computes alpha and transmittance in float32 (as a CPU rasterizer does),
    # the cached weights in float64: they agree to float32 accuracy, plus the rare pixel
    # whose alpha sits on the 1/255 threshold and is kept by one and dropped by the other.
    np.testing.assert_allclose(out.detach().numpy(), fast.detach().numpy(), atol=1e-4)
    np.testing.assert_allclose(dense_grad.numpy(), feats.grad.numpy(), atol=1e-4)


@pytest.mark.slow
def test_quick_benchmark_runs() -> None:
    from causalsplat.bench.render import NAME, run

    report = run(quick=True)
    assert report.name == NAME == "render"
    first = report.data["results"][0]
    assert first["dense"]["error"] == pytest.approx(first["rows"][0]["error"], rel=1e-2)
    assert first["rows"][0]["fb_ms"] < first["dense"]["fb_ms"]
    assert "| cap | T_min |" in report.markdown
    build = report.data["builds"][0]  # compiled kernel vs numpy path, same run
    assert build["same_pairs"] and build["max_weight_diff"] < 1e-6
    assert build["kernel_error"] == pytest.approx(build["numpy_error"], rel=1e-3)
    assert "compiled kernel" in report.markdown
