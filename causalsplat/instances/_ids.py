"""Entity and cluster ids numbered by first appearance, so that they do not depend on how
HDBSCAN, a merge or a split happened to number them."""

from __future__ import annotations

import numpy as np


def by_first_appearance(ids: np.ndarray, *others: np.ndarray) -> tuple[np.ndarray, ...]:
    """``ids`` renumbered 0.. in the order each value first appears in it, and ``others``
    mapped the same way; -1, and a value of ``others`` absent from ``ids``, become -1.

    >>> by_first_appearance(np.array([5, -1, 2, 5, 9]), np.array([9, 7, -1]))
    (array([ 0, -1,  1,  0,  2]), array([ 2, -1, -1]))
    """
    ids = np.asarray(ids)
    _, first = np.unique(ids, return_index=True)
    order = ids[np.sort(first)]
    order = order[order >= 0]
    size = max(int(np.max(a, initial=-1)) for a in (ids, *others)) + 2
    index_of = np.full(size, -1, dtype=np.int64)  # the last slot answers -1
    index_of[order] = np.arange(order.size)
    return tuple(index_of[np.asarray(a)] for a in (ids, *others))
