"""Row-wise helpers on sparse matrices, shared by the instance stage's modules."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp


def csr_row_argmax(m: sp.csr_matrix) -> tuple[np.ndarray, np.ndarray]:
    """Per row of a non-negative CSR matrix with sorted indices: the first column of its
    largest value and that value (column 0 and 0.0 for a row of zeros), as the dense
    ``argmax`` gives; scipy's own loops over the rows in Python.

    >>> best, value = csr_row_argmax(sp.csr_matrix(np.array([[0, 2.0, 2], [0, 0, 0]])))
    >>> best.tolist(), value.tolist()
    ([1, 0], [2.0, 0.0])
    """
    n = m.shape[0]
    best = np.zeros(n, dtype=np.int64)
    value = np.zeros(n, dtype=np.float64)
    lengths = np.diff(m.indptr)
    filled = np.flatnonzero(lengths > 0)
    if filled.size == 0:
        return best, value
    starts = m.indptr[:-1][filled]
    value[filled] = np.maximum.reduceat(m.data, starts)
    at_max = m.data == np.repeat(value, lengths)
    position = np.where(at_max, np.arange(m.data.shape[0]), m.data.shape[0])
    first = np.minimum.reduceat(position, starts)
    best[filled] = m.indices[first]
    best[value <= 0] = 0  # every entry of the row is 0
    return best, value


def csr_row_shares(m: sp.spmatrix) -> sp.csr_matrix:
    """A non-negative sparse matrix with each row divided by its sum (a row of zeros stays
    zero), as CSR.

    >>> csr_row_shares(sp.csr_matrix(np.array([[1.0, 3.0], [0.0, 0.0]]))).toarray().tolist()
    [[0.25, 0.75], [0.0, 0.0]]
    """
    m = sp.csr_matrix(m)
    total = np.asarray(m.sum(axis=1), dtype=np.float64).ravel()
    inv = np.divide(1.0, total, out=np.zeros_like(total), where=total > 0)
    return sp.csr_matrix(sp.diags(inv) @ m)
