"""Compiled kernels on chosen rows of a view's CSR weights (imports numba; imported lazily).

:func:`select_rows` is :meth:`causalsplat.render.types.Contributors.rows`: numpy builds an
index array as long as the selected weights and gathers through it; this copies each
selected row's slice straight into the output. :func:`rows_product` and
:func:`rows_transposed_product` render features at chosen pixels, and scatter their
gradient back, reading those rows in place: nothing is copied at all (the training's
steps, see :func:`causalsplat.render.render_features` with ``pixels``).
"""

from __future__ import annotations

import numpy as np

from causalsplat.render._jit import jit


@jit()
def _copy_rows(  # pragma: no cover - compiled
    indptr: np.ndarray,
    indices: np.ndarray,
    weights: np.ndarray,
    pixels: np.ndarray,
    out_indptr: np.ndarray,
    out_indices: np.ndarray,
    out_weights: np.ndarray,
) -> None:
    for i in range(pixels.shape[0]):
        start = indptr[pixels[i]]
        at = out_indptr[i]
        for k in range(indptr[pixels[i] + 1] - start):
            out_indices[at + k] = indices[start + k]
            out_weights[at + k] = weights[start + k]


def select_rows(
    indptr: np.ndarray, indices: np.ndarray, weights: np.ndarray, pixels: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(indptr, indices, weights) of the CSR rows ``pixels`` (int64), in that order."""
    indptr = np.asarray(indptr)
    lengths = indptr[pixels + 1] - indptr[pixels]
    out_indptr = np.zeros(pixels.shape[0] + 1, dtype=np.int64)
    np.cumsum(lengths, out=out_indptr[1:])
    out_indices = np.empty(int(out_indptr[-1]), dtype=np.asarray(indices).dtype)
    out_weights = np.empty(int(out_indptr[-1]), dtype=np.asarray(weights).dtype)
    _copy_rows(indptr, indices, weights, pixels, out_indptr, out_indices, out_weights)
    return out_indptr, out_indices, out_weights


@jit()
def rows_product(  # pragma: no cover - compiled
    indptr: np.ndarray,
    indices: np.ndarray,
    weights: np.ndarray,
    pixels: np.ndarray,
    values: np.ndarray,
    out: np.ndarray,
) -> None:
    """``out[i] = sum_k w_k values[g_k]`` over the CSR row ``pixels[i]`` (out zeroed)."""
    channels = values.shape[1]
    for i in range(pixels.shape[0]):
        p = pixels[i]
        for k in range(indptr[p], indptr[p + 1]):
            g = indices[k]
            w = weights[k]
            for c in range(channels):
                out[i, c] += w * values[g, c]


@jit()
def rows_transposed_product(  # pragma: no cover - compiled
    indptr: np.ndarray,
    indices: np.ndarray,
    weights: np.ndarray,
    pixels: np.ndarray,
    grad: np.ndarray,
    out: np.ndarray,
) -> None:
    """``out[g] += w * grad[i]`` for every weight ``w`` of Gaussian ``g`` in the CSR row
    ``pixels[i]``: the transposed product of :func:`rows_product`."""
    channels = grad.shape[1]
    for i in range(pixels.shape[0]):
        p = pixels[i]
        for k in range(indptr[p], indptr[p + 1]):
            g = indices[k]
            w = weights[k]
            for c in range(channels):
                out[g, c] += w * grad[i, c]


@jit()
def row_sums(indptr: np.ndarray, weights: np.ndarray, out: np.ndarray) -> None:  # pragma: no cover
    """``out[p]`` = the float64 sum of row ``p``'s weights, in their stored order."""
    for p in range(indptr.shape[0] - 1):
        total = 0.0
        for k in range(indptr[p], indptr[p + 1]):
            total += np.float64(weights[k])
        out[p] = total


__all__ = ["row_sums", "rows_product", "rows_transposed_product", "select_rows"]
