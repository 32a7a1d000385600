"""Where a random walk ends: absorption probabilities of a graph with absorbing nodes.

The solver behind :func:`causalsplat.instances.propagate.harmonic_labels`. Its system is
``L x = B``: ``L`` (S, S) the Laplacian of the free nodes (degree on the diagonal, minus
the free-free weights), ``B`` (S, K) each free node's weight to the fixed nodes of each
label. Row ``i`` of ``x`` gives, per label, the probability that the walk from free node
``i`` first reaches a fixed node of that label; with every node in a graph component that
holds a fixed node, each row sums to 1.

:func:`absorbing_labels` never raises on a well-formed system (every free node's component
reaching a fixed node), whatever its weights:

1. **Nearly closed components** (the walk leaves them with probability below
   :data:`NEARLY_CLOSED` per step: their weight to the fixed nodes over their total
   degree) are singular in floating point: ``1 + 1e-20 == 1`` drops the one weight that
   makes the block invertible. Real scenes make them: a Gaussian copied many times over
   (densified 3DGS) is a clique of copies whose edges to the rest of the surface weigh
   ``exp(-(d / s)**2)`` for ``s`` the tiny distance between copies. They are solved
   regularised (step 3).
2. The other components are solved exactly by one sparse LU factorisation, as if alone.
   A component where the factorisation fails, or a node's probabilities do not sum to 1
   within :data:`SUM_TOLERANCE` (an ill-conditioned block), is solved again regularised.
3. **Regularised**: ``L + RIDGE * D``, ``D`` the degrees (the mean degree for a node with
   none): a walk that dies with probability ``RIDGE`` per step. Strictly diagonally
   dominant, so it is never singular; when the walk leaves a component much more often
   than it dies the answer is the exact one to about ``RIDGE``, and when it leaves much
   less often the walk mixes over the component before it ends, so every node takes the
   label with the most weight out of the component (weighted by degree): the limit of
   the exact answer as the weights out vanish. If even this factorisation fails (out of
   memory, say), GMRES with a Jacobi preconditioner solves it column by column.
4. A node whose probabilities come out non-finite, or all zero (underflow), gets no label.

Memory: the right-hand side and the solution are made dense a block of columns at a time,
at most :data:`BLOCK_BYTES` each, so ``S x K`` floats are never held at once; only the
best label, its probability and the row sum of each node are kept. The LU factors of
``L`` remain the largest object.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import gmres, splu

#: Components whose walk leaves with a smaller probability per step are solved regularised.
NEARLY_CLOSED = 1e-8
#: Probability per step that the regularised walk dies (relative diagonal shift of ``L``).
RIDGE = 1e-10
#: An exact solution is kept where each node's probabilities sum to 1 within this.
SUM_TOLERANCE = 1e-8
#: Most bytes of dense right-hand side (and of solution) held at once.
BLOCK_BYTES = 64 * 2**20
#: Relative residual at which GMRES (the last resort) stops, and its most restarts.
GMRES_TOLERANCE = 1e-10
GMRES_RESTARTS = 200

_FACTOR_ERRORS = (RuntimeError, ValueError, MemoryError)  # what splu raises when it fails
# scipy < 1.12 names GMRES's relative tolerance ``tol``, later ones ``rtol``.
_RTOL = "rtol" if "rtol" in inspect.signature(gmres).parameters else "tol"


@dataclass(frozen=True, slots=True)
class Absorption:
    """The most probable label of each free node.

    Attributes:
        label: (S,) int64 the label whose fixed nodes the walk most likely reaches first
            (ties: the smaller label), -1 when none could be found (step 4).
        probability: (S,) float64 that probability (0 where ``label`` is -1).
        regularised: (S,) bool whether the node's component was solved regularised.
    """

    label: np.ndarray
    probability: np.ndarray
    regularised: np.ndarray


@dataclass(slots=True)
class _Best:
    """Running best column of a solution read a block of columns at a time."""

    label: np.ndarray
    value: np.ndarray
    total: np.ndarray
    finite: np.ndarray

    @classmethod
    def empty(cls, n: int) -> _Best:
        return cls(np.full(n, -1, np.int64), np.full(n, -np.inf), np.zeros(n), np.ones(n, bool))

    def update(self, start: int, x: np.ndarray) -> None:
        """Take in the solution columns ``start...`` (a dense (n, c) block)."""
        self.finite &= np.isfinite(x).all(axis=1)
        self.total += x.sum(axis=1)
        col = x.argmax(axis=1)
        top = x[np.arange(x.shape[0]), col]
        better = top > self.value  # strictly: an earlier (smaller) label wins a tie
        self.label[better] = start + col[better]
        self.value[better] = top[better]


def absorbing_labels(
    laplacian: sp.spmatrix, rhs: sp.spmatrix, degree: np.ndarray, component: np.ndarray
) -> Absorption:
    """Solve ``laplacian @ x = rhs`` robustly and take each row's best column (module
    docstring).

    ``laplacian`` (S, S) and ``rhs`` (S, K) sparse, non-negative weights; ``degree`` (S,)
    each node's total weight (the diagonal of ``laplacian`` plus any self loop);
    ``component`` (S,) int the graph component of each node (no edge joins two).
    """
    n = laplacian.shape[0]
    laplacian, rhs = sp.csc_matrix(laplacian), sp.csr_matrix(rhs)
    comp = np.unique(np.asarray(component), return_inverse=True)[1].ravel()
    leaving = np.asarray(rhs.sum(axis=1)).ravel()
    ratio = _ratio(np.bincount(comp, leaving), np.bincount(comp, degree))
    redo = ratio[comp] < NEARLY_CLOSED
    label, value = np.full(n, -1, np.int64), np.zeros(n)
    exact = np.flatnonzero(~redo)
    if exact.size:
        best = _solve_exact(_block(laplacian, exact, n), rhs[exact])
        ok = np.zeros(exact.size, bool) if best is None else _sums_to_one(best)
        redo[np.isin(comp, comp[exact[~ok]])] = True  # the whole component of a bad node
        good = ok & ~redo[exact]
        if best is not None:
            label[exact[good]], value[exact[good]] = best.label[good], best.value[good]
    again = np.flatnonzero(redo)
    if again.size:
        best = _solve_regularised(_block(laplacian, again, n), rhs[again], degree[again])
        answered = best.finite & (best.value > 0)
        label[again[answered]] = best.label[answered]
        value[again[answered]] = best.value[answered]
    return Absorption(label=label, probability=value, regularised=redo)


def _ratio(num: np.ndarray, den: np.ndarray) -> np.ndarray:
    """``num / den`` elementwise, 0 where ``den`` is 0."""
    return np.divide(num, den, out=np.zeros_like(num, dtype=np.float64), where=den > 0)


def _block(matrix: sp.csc_matrix, nodes: np.ndarray, n: int) -> sp.csc_matrix:
    """``matrix`` restricted to ``nodes`` (no copy when they are all of them)."""
    return matrix if nodes.size == n else matrix[nodes][:, nodes].tocsc()


def _sums_to_one(best: _Best) -> np.ndarray:
    return best.finite & (np.abs(best.total - 1.0) <= SUM_TOLERANCE)


def _solve_exact(laplacian: sp.csc_matrix, rhs: sp.csr_matrix) -> _Best | None:
    """The exact solution's best columns, or ``None`` when the factorisation fails."""
    try:
        lu = splu(laplacian)
    except _FACTOR_ERRORS:
        return None
    return _best_columns(lu.solve, rhs)


def _solve_regularised(laplacian: sp.csc_matrix, rhs: sp.csr_matrix, degree: np.ndarray) -> _Best:
    """The best columns of ``(L + RIDGE * D) x = rhs`` (step 3), by LU or else GMRES."""
    mean = float(degree.mean()) if degree.size else 0.0
    shift = RIDGE * np.where(degree > 0, degree, mean if mean > 0 else 1.0)
    matrix = (laplacian + sp.diags(shift)).tocsc()
    try:
        solve: Callable[[np.ndarray], np.ndarray] = splu(matrix).solve
    except _FACTOR_ERRORS:

        def solve(block: np.ndarray) -> np.ndarray:
            return _gmres_columns(matrix, block)

    return _best_columns(solve, rhs)


def _best_columns(solve: Callable[[np.ndarray], np.ndarray], rhs: sp.csr_matrix) -> _Best:
    """Solve for ``rhs`` a block of at most :data:`BLOCK_BYTES` of columns at a time."""
    n, k = rhs.shape
    width = max(1, BLOCK_BYTES // (8 * max(n, 1)))
    best = _Best.empty(n)
    columns = rhs.tocsc()
    for start in range(0, k, width):
        block = columns[:, start : start + width].toarray()
        best.update(start, np.asarray(solve(block)).reshape(n, -1))
    return best


def _gmres_columns(matrix: sp.csc_matrix, block: np.ndarray) -> np.ndarray:
    """Each column of ``matrix @ x = block`` by Jacobi-preconditioned GMRES; a column that
    does not converge is NaN (its nodes then get no label)."""
    precondition = sp.diags(1.0 / matrix.diagonal())
    out = np.zeros(block.shape)
    for j in range(block.shape[1]):
        if not block[:, j].any():
            continue
        x, info = gmres(matrix, block[:, j], M=precondition, atol=0.0,
                        maxiter=GMRES_RESTARTS, **{_RTOL: GMRES_TOLERANCE})  # fmt: skip
        out[:, j] = x if info == 0 else np.nan
    return out
