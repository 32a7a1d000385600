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
