"""One object, one piece: an entity whose Gaussians lie in far-apart pieces is split.

A window seen in three views and a box on a shelf two metres away can end in one cluster:
the few masks of the window have features close enough to the box's for HDBSCAN, and
every Gaussian then votes for it. No object is two pieces metres apart, so such an entity
is cut where its Gaussians are:

1. **Pieces** (:func:`pieces`): the Gaussians are put in cubic cells of side ``gap``; two
   occupied cells that touch (26-neighbourhood) are one piece. Gaussians less than
   ``gap`` apart are always in one piece, more than ``2 √3 gap`` apart never: the cells
   keep the cost linear in the Gaussians, however dense the capture.
2. **Split** (:func:`split_pieces`): every piece holding at least ``min_share`` of its
   entity's Gaussians (and ``min_gaussians``) is a candidate; each of the entity's masks
   goes to the candidate holding most of its weight, and every candidate that received a
   mask becomes an entity of its own, labelled by those masks. The rest (small pieces,
   pieces no mask chose) stay with the piece holding most Gaussians. Entities listed in
   ``keep`` (the floor, the ceiling: one structure however far apart its parts) are not
   split.

>>> import numpy as np, scipy.sparse as sp
>>> means = np.array([[0., 0, 0], [0.05, 0, 0], [3, 0, 0], [3.05, 0, 0]])
>>> pieces(means, 0.1).tolist()
[0, 0, 1, 1]
>>> weight = sp.csr_matrix(np.array([[1., 1, 0, 0], [0, 0, 1, 1], [1, 1, 0, 0]]))
>>> labels, masks = split_pieces(np.zeros(4, int), np.zeros(3, int), weight, means, gap=0.1,
...                              min_share=0.2, min_gaussians=1)
>>> labels.tolist(), masks.tolist()
([0, 0, 1, 1], [0, 1, 0])
"""

from __future__ import annotations

from collections.abc import Collection

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

#: The 13 cell offsets "after" a cell: with their opposites, its 26 neighbours.
_STEPS = (-1, 0, 1)
_FORWARD = np.array(
    [(i, j, k) for i in _STEPS for j in _STEPS for k in _STEPS if (i, j, k) > (0, 0, 0)],
    dtype=np.int64,
)


def pieces(means: np.ndarray, gap: float) -> np.ndarray:
    """(N,) int64 piece of each of the (N, 3) points (module docstring), numbered from 0."""
    pts = np.asarray(means, dtype=np.float64)
    if pts.shape[0] == 0:
        return np.zeros(0, dtype=np.int64)
    cell = np.floor((pts - pts.min(axis=0)) / gap).astype(np.int64)
    span = cell.max(axis=0) + 3  # room for the -1 / +1 offsets on every axis
    cell += 1

    def key(c: np.ndarray) -> np.ndarray:
        return (c[:, 0] * span[1] + c[:, 1]) * span[2] + c[:, 2]

    cells, of_point = np.unique(key(cell), return_inverse=True)
    occupied = np.unique(cell, axis=0)  # same order as ``cells`` (key is monotone)
    src, dst = [], []
    for offset in _FORWARD:
        other = key(occupied + offset)
        at = np.searchsorted(cells, other)
        hit = (at < cells.size) & (cells[np.minimum(at, cells.size - 1)] == other)
        src.append(np.flatnonzero(hit))
        dst.append(at[hit])
    a, b = np.concatenate(src), np.concatenate(dst)
    graph = sp.coo_matrix((np.ones(a.size), (a, b)), shape=(cells.size, cells.size))
    _, component = connected_components(graph, directed=False)
    return component[of_point.ravel()].astype(np.int64)


def split_pieces(
    labels: np.ndarray,
    mask_entity: np.ndarray,
    weight: sp.csr_matrix,
    means: np.ndarray,
    *,
    gap: float,
    min_share: float,
    min_gaussians: int,
    keep: Collection[int] = (),
) -> tuple[np.ndarray, np.ndarray]:
    """Entity labels (N,) and mask entities (M,) with far-apart pieces split (module
    docstring); new entities take ids after the existing ones. ``weight`` (M, N): how much
    of each Gaussian each mask draws."""
    labels = np.asarray(labels, dtype=np.int64).copy()
    mask_entity = np.asarray(mask_entity, dtype=np.int64).copy()
    if not (np.isfinite(gap) and gap > 0) or not (labels >= 0).any():
        return labels, mask_entity
    weight = sp.csr_matrix(weight)
    nxt = int(max(labels.max(), mask_entity.max(initial=-1))) + 1
    for k in np.unique(labels[labels >= 0]).tolist():
        if k in keep:
            continue
        idx = np.flatnonzero(labels == k)
        piece = pieces(np.asarray(means)[idx], gap)
        sizes = np.bincount(piece)
        big = np.flatnonzero((sizes >= min_share * idx.size) & (sizes >= min_gaussians))
        rows = np.flatnonzero(mask_entity == k)
        if big.size < 2 or rows.size == 0:
            continue
        drawn = weight[rows][:, idx].tocsr()  # (masks, Gaussians of k)
        onto = sp.csr_matrix((np.ones(idx.size), (np.arange(idx.size), piece)),
                             shape=(idx.size, sizes.size))  # fmt: skip
        per_piece = np.asarray((drawn @ onto).todense())[:, big]
        choice = big[np.argmax(per_piece, axis=1)]
        chosen = [p for p in big.tolist() if p in set(choice.tolist())]
        if len(chosen) < 2:
            continue
        main = max(chosen, key=lambda p: (sizes[p], -p))
        new_id = {main: k}
        for p in chosen:
            if p != main:
                new_id[p] = nxt
                nxt += 1
        for p, e in new_id.items():
            if e != k:
                labels[idx[piece == p]] = e
        mask_entity[rows] = [new_id[int(p)] for p in choice]
    return labels, mask_entity
