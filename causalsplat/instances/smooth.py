"""Votes smoothed along surfaces: a well-seen Gaussian's vote against its neighbours'.

Noisy masks leave wrong votes in patches: a fragment mask that one view draws across two
objects, a merged mask, the border of two masks that a view's jitter moved. Each such
Gaussian sees well, and votes wrongly, while the surface around it votes rightly. Before
the weakly seen Gaussians take their labels from the well-seen ones
(:mod:`causalsplat.instances.propagate`), the well-seen ones' votes are smoothed along the
same surface graph:

A random walk from a Gaussian ``i`` moves along the graph's edges (in proportion to their
weights) and, at each Gaussian ``j`` it visits, stops with probability
``lambda_j / (d_j + lambda_j)``, ``d_j`` the total weight of ``j``'s edges and
``lambda_j = min(c_j, CONFIDENCE_CAP) * d_j / smoothing``, ``c_j >= 0`` how well ``j`` is
seen; where it stops it takes a cluster by ``j``'s vote shares ``Y_j``. The probabilities
of where the walk ends, ``F = (D + Lambda - W)^-1 Lambda Y`` (label spreading with a prior,
Zhou et al., 2004), give each Gaussian the cluster it most likely takes. With
``smoothing = 10`` a Gaussian seen as well as the median one keeps its own vote with
probability 1/11 and looks along the surface otherwise: a patch of wrong votes inside a
surface voting rightly goes to the surface, while a surface that votes as one, however
small, keeps its vote (every Gaussian of it stops on a vote for it). Edges between objects
are weak (the graph's feature agreement and planes), so one object's votes rarely cross
into another's.

The system ``F = M F + C`` (``M = (D + Lambda)^-1 W``, ``C = (D + Lambda)^-1 Lambda Y``)
is solved by Jacobi iterations with Chebyshev acceleration (Golub and Van Loan, Matrix
Computations, 11.2.8): ``M`` is similar to a symmetric matrix, so its eigenvalues are real
and within ``[-rho, rho]``, ``rho = max d / (d + lambda) < 1`` its largest row sum, and
``F_{k+1} = omega_{k+1} (M F_k + C) + (1 - omega_{k+1}) F_{k-1}`` with the Chebyshev
weights ``omega`` takes about ``sqrt(1 / (1 - rho))`` steps where plain Jacobi takes
``1 / (1 - rho)`` (on scene0000_00's Gaussians about 30 instead of 150). ``F`` is kept
sparse (entries of magnitude below :data:`PRUNE` dropped), so the memory grows with the
votes a neighbourhood holds, not with Gaussians x clusters. The iterations stop once no
entry of ``F`` can be more than :data:`TOLERANCE` from the solution (the residual
``M F + C - F`` at most ``TOLERANCE (1 - rho)`` everywhere, since the error is
``(I - M)^-1`` times it), or after :data:`MAX_ITERATIONS`: the labels, not the
probabilities, are the output, and a label whose walk ends on two clusters within a few
hundredths of each other is a tie either way.
:func:`smoothed_shares` is held to a direct float64 solve by the tests.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from causalsplat.instances._sparse import csr_row_argmax
from causalsplat.instances.propagate import edge_weights

#: A Gaussian's confidence counts up to this (three times the median evidence): one seen
#: very often still yields to a surface that votes otherwise all around it.
CONFIDENCE_CAP = 3.0
#: Entries of ``F`` of magnitude below this are dropped after each iteration.
PRUNE = 1e-6
#: The largest error of ``F`` the iterations stop at (module docstring), unless they
#: reach :data:`MAX_ITERATIONS` first (a contraction very close to 1: nodes of tiny
#: confidence, or a very large ``smoothing``).
TOLERANCE = 1e-2
MAX_ITERATIONS = 200


def smoothed_labels(
    graph: sp.spmatrix, shares: sp.spmatrix, confidence: np.ndarray, smoothing: float
) -> np.ndarray:
    """(N,) int64: the cluster each node's walk most likely ends on (module docstring);
    -1 for a node no vote reaches. Arguments as :func:`smoothed_shares`'s; ties go to
    the smaller cluster.

    A path of five nodes, the middle one voting otherwise than the rest:

    >>> path = sp.diags([np.ones(4), np.ones(4)], [-1, 1], shape=(5, 5))
    >>> votes = sp.csr_matrix(np.array([[1.0, 0], [1, 0], [0, 1], [1, 0], [1, 0]]))
    >>> smoothed_labels(path, votes, np.ones(5), 10.0).tolist()  # the middle one yields
    [0, 0, 0, 0, 0]
    >>> smoothed_labels(path, votes, np.ones(5), 0.1).tolist()  # each keeps its own
    [0, 0, 1, 0, 0]
    """
    f = smoothed_shares(graph, shares, confidence, smoothing)
    f.sort_indices()
    best, value = csr_row_argmax(f)
    return np.where(value > 0, best, -1)


def smoothed_shares(
    graph: sp.spmatrix, shares: sp.spmatrix, confidence: np.ndarray, smoothing: float
) -> sp.csr_matrix:
    """(N, K) ``F`` of the module docstring: where each node's walk ends, by cluster.

    ``graph`` (N, N) symmetric weights (a weight that is not finite and positive is no
    edge); ``shares`` (N, K) non-negative vote shares, each row summing to 1 (a node that
    voted) or 0; ``confidence`` (N,) >= 0; ``smoothing`` > 0. A node without edges keeps
    its own vote.
    """
    if not smoothing > 0:
        raise ValueError(f"smoothing must be > 0, got {smoothing!r}")
    weights = edge_weights(graph)
    n = weights.shape[0]
    y = sp.csr_matrix(shares, dtype=np.float64)
    if y.shape[0] != n:
        raise ValueError(f"shares has {y.shape[0]} rows for a graph of {n} nodes")
    degree = np.asarray(weights.sum(axis=1)).ravel()
    conf = np.minimum(np.clip(np.asarray(confidence, dtype=np.float64), 0.0, None),
                      CONFIDENCE_CAP)  # fmt: skip
    stop = conf * np.where(degree > 0, degree, 1.0) / smoothing
    total = degree + stop
    inv = np.divide(1.0, total, out=np.zeros(n), where=total > 0)
    prior = sp.csr_matrix(sp.diags(stop * inv) @ y)
    step = sp.csr_matrix(sp.diags(inv) @ weights)
    rho = float(np.max(degree * inv, initial=0.0))  # the contraction, < 1
    enough = TOLERANCE * (1.0 - rho)
    f, before = y.copy(), None
    omega = 1.0
    for _ in range(MAX_ITERATIONS):
        jacobi = sp.csr_matrix(step @ f + prior)
        residual = abs(jacobi - f)
        if residual.nnz == 0 or residual.max() <= enough:
            return jacobi
        if before is None:  # the first step is Jacobi's
            nxt, omega = jacobi, 2.0 / (2.0 - rho * rho)
        else:
            nxt = sp.csr_matrix(omega * jacobi + (1.0 - omega) * before)
            omega = 1.0 / (1.0 - rho * rho * omega / 4.0)
        nxt.data[np.abs(nxt.data) < PRUNE] = 0.0
        nxt.eliminate_zeros()
        before, f = f, nxt
    return f
