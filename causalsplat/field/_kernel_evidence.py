"""Compiled ``B @ W`` for a view: mask weights times blending weights (imports numba).

``B`` (M, H*W) holds the view's weighted masks and ``W`` (H*W, N) its blending weights,
both CSR. Row ``m`` of the product is the weight each Gaussian carries inside mask ``m``,
``sum_x B_m(x) w(x, g)``. scipy's product needs ``W`` as float64 (a copy of every weight
of the view) to sum in float64; these kernels read the float32 weights in place and sum
in float64, in two passes over the mask pixels' rows: count each row's Gaussians, then
write them (columns in order of first touch).
"""

from __future__ import annotations

import numpy as np

from causalsplat.render._jit import jit


@jit()
def _count(  # pragma: no cover - compiled
    b_indptr: np.ndarray,
    b_indices: np.ndarray,
    w_indptr: np.ndarray,
    w_indices: np.ndarray,
    seen: np.ndarray,
    counts: np.ndarray,
) -> None:
    for m in range(b_indptr.shape[0] - 1):
        n = 0
        for j in range(b_indptr[m], b_indptr[m + 1]):
            x = b_indices[j]
            for k in range(w_indptr[x], w_indptr[x + 1]):
                g = w_indices[k]
                if seen[g] != m:
                    seen[g] = m
                    n += 1
        counts[m] = n


@jit()
def _fill(  # pragma: no cover - compiled
    b_indptr: np.ndarray,
    b_indices: np.ndarray,
    b_data: np.ndarray,
    w_indptr: np.ndarray,
    w_indices: np.ndarray,
    w_data: np.ndarray,
    slot: np.ndarray,
    out_indptr: np.ndarray,
    out_indices: np.ndarray,
    out_data: np.ndarray,
) -> None:
    for m in range(b_indptr.shape[0] - 1):
        end = out_indptr[m]
        for j in range(b_indptr[m], b_indptr[m + 1]):
            x = b_indices[j]
            bw = np.float64(b_data[j])
            for k in range(w_indptr[x], w_indptr[x + 1]):
                g = w_indices[k]
                at = slot[g]
                if at < out_indptr[m] or at >= end or out_indices[at] != g:
                    at = end
                    slot[g] = at
                    out_indices[at] = g
                    out_data[at] = 0.0
                    end += 1
                out_data[at] += bw * np.float64(w_data[k])


def mask_times_weights(
    b_indptr: np.ndarray,
    b_indices: np.ndarray,
    b_data: np.ndarray,
    w_indptr: np.ndarray,
    w_indices: np.ndarray,
    w_data: np.ndarray,
    n_columns: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(indptr, indices, data float64) of the CSR product ``B @ W`` (module docstring)."""
    m = b_indptr.shape[0] - 1
    seen = np.full(n_columns, -1, dtype=np.int64)
    counts = np.zeros(m, dtype=np.int64)
    _count(b_indptr, b_indices, w_indptr, w_indices, seen, counts)
    out_indptr = np.zeros(m + 1, dtype=np.int64)
    np.cumsum(counts, out=out_indptr[1:])
    out_indices = np.zeros(int(out_indptr[-1]), dtype=np.int32)
    out_data = np.zeros(int(out_indptr[-1]), dtype=np.float64)
    slot = np.zeros(n_columns, dtype=np.int64)
    _fill(b_indptr, b_indices, b_data, w_indptr, w_indices, w_data, slot,
          out_indptr, out_indices, out_data)  # fmt: skip
    return out_indptr, out_indices, out_data


__all__ = ["mask_times_weights"]
