"""Compiled kernels on chosen rows of a view's CSR weights (imports numba; imported lazily).

:func:`rows_product` and :func:`rows_transposed_product` render features at chosen pixels,
and scatter their gradient back, reading those rows of the view's CSR in place: nothing is
copied (the training's steps; :meth:`causalsplat.render.types.Contributors.composite_rows`).
Without numba the same products go through a copy of the rows
(:meth:`~causalsplat.render.types.Contributors.rows`). :func:`row_sums` is the accumulated
alpha.
"""

from __future__ import annotations

import numpy as np

from causalsplat.render._jit import jit


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


__all__ = ["row_sums", "rows_product", "rows_transposed_product"]
