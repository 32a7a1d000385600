"""The compiled mask x blending-weight product against scipy's float64 product."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from causalsplat.field._kernel_evidence import mask_times_weights


@pytest.mark.parametrize("seed", range(4))
def test_mask_times_weights_is_the_float64_product(seed: int) -> None:
    rng = np.random.default_rng(seed)
    pixels, n, m = 300, 90, 7
    w = sp.random(pixels, n, density=0.06, random_state=seed, format="csr", dtype=np.float32)
    w.data = rng.random(w.nnz).astype(np.float32)
    w.indices = w.indices.astype(np.int32)
    b = sp.random(m, pixels, density=0.2, random_state=seed + 10, format="csr", dtype=np.float32)
    b.data = (0.4 + 0.6 * rng.random(b.nnz)).astype(np.float32)
    b.data[b.indptr[m - 1] :] = 0.0  # the last mask row loses its pixels
    b.eliminate_zeros()
    indptr, indices, data = mask_times_weights(b.indptr, b.indices, b.data, w.indptr,
                                               w.indices, w.data, n)  # fmt: skip
    got = sp.csr_matrix((data, indices, indptr), shape=(m, n))
    want = b.astype(np.float64) @ w.astype(np.float64)
    assert got.nnz == want.nnz and data.dtype == np.float64
    np.testing.assert_allclose(got.toarray(), want.toarray(), rtol=1e-12, atol=0)
    # each row lists each Gaussian once
    for r in range(m):
        row = indices[indptr[r] : indptr[r + 1]]
        assert np.unique(row).size == row.size


@pytest.mark.parametrize("compiled", [True, False])
def test_uplift_and_supervision_are_their_per_pixel_definitions(
    compiled: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``f = sum_v W_v^T (B_v^T R_v)`` and ``s = sum_v W_v^T 1[covered]`` in float64, from
    per-pixel codes, against the accumulator's ``(B W)^T R`` (compiled and scipy paths)."""
    from causalsplat.field import FieldConfig
    from causalsplat.field.uplift import UpliftAccumulator
    from causalsplat.field.weights import normalize_rows, view_masks
    from causalsplat.masks import MaskSet
    from causalsplat.render import _backend, build_contributors
    from tests.causalsplat.render.conftest import make_camera, make_random_scene

    monkeypatch.setattr(_backend, "numba_available", lambda: compiled)
    scene = make_random_scene(5, n=60)
    rng = np.random.default_rng(0)
    acc = UpliftAccumulator(scene.n, 4, np.random.default_rng(9))
    codes_rng = np.random.default_rng(9)
    want_f, want_s = np.zeros((scene.n, 4)), np.zeros(scene.n)
    for v in range(3):
        cam = make_camera(distance=3.0 + v)
        contrib = build_contributors(scene, cam, cache=False)
        masks = rng.random((4, cam.height, cam.width)) < 0.3
        vm = view_masks(MaskSet("v", masks), v, FieldConfig(min_mask_pixels=1), rng)
        acc.add(contrib, vm)
        r = normalize_rows(codes_rng.standard_normal((vm.n_masks, 4)))
        w = contrib.matrix(np.float64).toarray()  # (H*W, N)
        per_pixel = vm.weights.toarray().astype(np.float64).T @ r
        want_f += w.T @ per_pixel
        covered = np.zeros(vm.n_pixels)
        covered[vm.pixels] = 1.0
        want_s += w.T @ covered
    assert acc.codes is not None and np.abs(want_f).max() > 0.1
    np.testing.assert_allclose(acc.codes, want_f, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(acc.supervision, want_s, rtol=1e-9, atol=1e-12)
