"""Compiled ``W^T @ g`` straight from a view's CSR weights (imports numba; imported lazily).

The backward pass of a feature render needs ``W^T @ g`` (N, C). Building ``W^T`` as a
second CSR matrix costs a copy of every weight and a pass as long as the product itself;
scattering each row of ``W`` into the Gaussians' rows reads ``W`` once in its stored
order. Rows are split into ranges, each range scattered into its own (N, C) buffer by one
thread and the buffers summed in range order: the result does not depend on timing (the
thread count changes only the order of the float additions).
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np

from causalsplat.render._jit import jit


@jit()
def _scatter_rows(  # pragma: no cover - compiled
    indptr: np.ndarray,
    indices: np.ndarray,
    weights: np.ndarray,
    grad: np.ndarray,
    out: np.ndarray,
    first: int,
    last: int,
) -> None:
    channels = grad.shape[1]
    for row in range(first, last):
        for k in range(indptr[row], indptr[row + 1]):
            g = indices[k]
            w = weights[k]
            for c in range(channels):
                out[g, c] += w * grad[row, c]


def transposed_product(
    indptr: np.ndarray,
    indices: np.ndarray,
    weights: np.ndarray,
    grad: np.ndarray,
    n_columns: int,
    threads: int,
) -> np.ndarray:
    """(n_columns, C) ``W^T @ grad`` for the CSR ``W`` (rows x n_columns), in grad's dtype.

    On one thread the result does not depend on anything but the inputs; it equals scipy's
    ``W.T @ grad`` (weights cast to grad's dtype) up to the rounding of the additions.
    """
    grad = np.ascontiguousarray(grad)
    rows = indptr.shape[0] - 1
    threads = max(1, min(threads, rows))
    bounds = np.linspace(0, rows, threads + 1).astype(np.int64)
    outs = [np.zeros((n_columns, grad.shape[1]), dtype=grad.dtype) for _ in range(threads)]
    data = weights  # float32 weights times float64 values are float64 products: no copy

    def task(i: int) -> None:
        _scatter_rows(indptr, indices, data, grad, outs[i], int(bounds[i]), int(bounds[i + 1]))

    if threads == 1:
        task(0)
    else:
        with ThreadPoolExecutor(threads) as pool:
            list(pool.map(task, range(threads)))
    total = outs[0]
    for part in outs[1:]:
        total += part
    return total


__all__ = ["transposed_product"]
