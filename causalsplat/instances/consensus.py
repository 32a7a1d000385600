"""Multi-view consensus: clusters of masks that show the same Gaussians are one object.

HDBSCAN groups masks by their features alone. When the field gives one object's masks
from two sets of views features far enough apart (its front and its back, a bed seen
from the door and from the pillow end), the object becomes two clusters, and its
Gaussians are shared between two entities. The masks themselves say otherwise: the
views of both clusters draw the *same* Gaussians inside them. Two objects side by side
share only the Gaussians of their common border.

For clusters ``a`` and ``b``, with ``v_a(g)`` the views' votes of Gaussian ``g`` for
``a`` (step 3 of :mod:`causalsplat.instances.assign`, feature agreement left out), the
*overlap* is ``sum_g min(v_a(g), v_b(g)) / min(V_a, V_b)`` with ``V_a = sum_g v_a(g)``:
the share of the smaller cluster's votes that fall on Gaussians the other one claims as
much. Clusters whose overlap reaches ``threshold`` are merged (transitively).

>>> import numpy as np, scipy.sparse as sp
>>> votes = sp.csr_matrix(np.array([[2., 1., 0.], [3., 2., 0.], [0., 0., 4.], [0., .2, 3.]]))
>>> np.round(overlaps(votes), 2)
array([[1.  , 0.94, 0.  ],
       [0.94, 1.  , 0.06],
       [0.  , 0.06, 1.  ]])
>>> merged_clusters(np.array([0, 1, 2, 1, -1]), votes, 0.5).tolist()
[0, 0, 1, 0, -1]
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from causalsplat.instances._ids import by_first_appearance


def overlaps(votes: sp.csr_matrix) -> np.ndarray:
    """(K, K) overlap of every pair of clusters (module docstring); the diagonal is 1
    for a cluster with votes."""
    m = sp.csr_matrix(votes, dtype=np.float64)
    m.sum_duplicates()
    k = m.shape[1]
    shared = np.zeros((k, k), dtype=np.float64)
    lengths = np.diff(m.indptr)
    starts = np.repeat(m.indptr[:-1], lengths)
    ends = np.repeat(m.indptr[1:], lengths)
    position = np.arange(m.data.size)
    # every pair of entries in one row, by their distance d within the row
    for d in range(1, int(lengths.max(initial=0))):
        first = position[(position + d < ends) & (position >= starts)]
        if first.size == 0:
            break
        a, b = m.indices[first], m.indices[first + d]
        np.add.at(shared, (a, b), np.minimum(m.data[first], m.data[first + d]))
    shared = shared + shared.T
    total = np.asarray(m.sum(axis=0)).ravel()
    np.fill_diagonal(shared, total)
    smaller = np.minimum.outer(total, total)
    return np.divide(shared, smaller, out=np.zeros_like(shared), where=smaller > 0)


def merged_clusters(
    cluster: np.ndarray,
    votes: sp.csr_matrix,
    threshold: float,
    alike: np.ndarray | None = None,
) -> np.ndarray:
    """Each mask's cluster after merging clusters whose overlap reaches ``threshold``
    (and, where ``alike`` (K, K) is given, that it marks alike), renumbered 0.. in the
    order of each merged cluster's first mask; -1 stays -1."""
    k = votes.shape[1]
    if k < 2:
        return cluster
    together = overlaps(votes) >= threshold
    if alike is not None:
        together &= alike
    return joined_clusters(cluster, together)


def joined_clusters(cluster: np.ndarray, together: np.ndarray) -> np.ndarray:
    """Each mask's cluster after joining the clusters ``together`` (K, K) marks
    (transitively), renumbered 0.. in the order of each joined cluster's first mask; -1
    stays -1."""
    _, component = connected_components(sp.csr_matrix(together), directed=False)
    merged = np.where(cluster >= 0, component[np.maximum(cluster, 0)], -1)
    return by_first_appearance(merged)[0]
