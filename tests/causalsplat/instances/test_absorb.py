"""The absorption solver against a dense float64 solve, and each of its fallbacks."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from causalsplat.instances import _absorb
from causalsplat.instances._absorb import Absorption, absorbing_labels
from causalsplat.instances.propagate import harmonic_labels


def _well_posed(seed: int = 0, n: int = 80, n_labels: int = 4) -> tuple[sp.csr_matrix, ...]:
    """A connected random graph (a chain plus random edges, weights in [0.1, 1]) with a
    quarter of its nodes fixed; returns the graph, labels and the fixed mask."""
    rng = np.random.default_rng(seed)
    i = np.r_[np.arange(n - 1), rng.integers(0, n, 3 * n)]
    j = np.r_[np.arange(1, n), rng.integers(0, n, 3 * n)]
    keep = i != j
    w = sp.coo_matrix((rng.uniform(0.1, 1.0, keep.sum()), (i[keep], j[keep])), shape=(n, n))
    graph = w.tocsr().maximum(w.T.tocsr()).tocsr()
    fixed = rng.random(n) < 0.25
    labels = np.where(fixed, rng.integers(0, n_labels, n), -1)
    return graph, labels, fixed


def _system(graph: sp.csr_matrix, labels: np.ndarray, fixed: np.ndarray) -> tuple:
    """The free nodes' Laplacian, right-hand side and degrees, as harmonic_labels builds
    them (every free node of these graphs reaches a fixed one)."""
    free, known = np.flatnonzero(~fixed), np.flatnonzero(fixed)
    rows = graph[free]
    degree = np.asarray(rows.sum(axis=1)).ravel()
    laplacian = sp.diags(degree) - rows[:, free]
    onehot = np.eye(labels.max() + 1)[labels[known]]
    return laplacian, sp.csr_matrix(rows[:, known] @ onehot), degree


def _dense_reference(laplacian: sp.spmatrix, rhs: sp.spmatrix) -> np.ndarray:
    return np.linalg.solve(laplacian.toarray(), rhs.toarray())


def _solve(graph: sp.csr_matrix, labels: np.ndarray, fixed: np.ndarray) -> Absorption:
    laplacian, rhs, degree = _system(graph, labels, fixed)
    return absorbing_labels(laplacian, rhs, degree, np.zeros(laplacian.shape[0], np.int64))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_well_posed_graphs_match_a_dense_float64_solve(seed: int) -> None:
    graph, labels, fixed = _well_posed(seed)
    laplacian, rhs, _ = _system(graph, labels, fixed)
    ref = _dense_reference(laplacian, rhs)
    np.testing.assert_allclose(ref.sum(axis=1), 1.0, atol=1e-12)  # the walk always ends
    got = _solve(graph, labels, fixed)
    assert not got.regularised.any()
    np.testing.assert_array_equal(got.label, ref.argmax(axis=1))
    np.testing.assert_allclose(got.probability, ref.max(axis=1), rtol=0, atol=1e-9)
    out = harmonic_labels(graph, labels, fixed)
    np.testing.assert_array_equal(out[~fixed], ref.argmax(axis=1))
    np.testing.assert_array_equal(out[fixed], labels[fixed])


def test_solving_one_column_at_a_time_changes_nothing(monkeypatch: pytest.MonkeyPatch) -> None:
    graph, labels, fixed = _well_posed(3, n_labels=6)
    whole = _solve(graph, labels, fixed)
    monkeypatch.setattr(_absorb, "BLOCK_BYTES", 1)  # one column per block
    split = _solve(graph, labels, fixed)
    # the blocks sum in another order: equal to rounding, not bit for bit
    np.testing.assert_array_equal(split.label, whole.label)
    np.testing.assert_allclose(split.probability, whole.probability, rtol=1e-12, atol=1e-15)


def test_ties_go_to_the_smaller_label_across_blocks(monkeypatch: pytest.MonkeyPatch) -> None:
    # free node 0 between fixed 1 (label 2) and fixed 2 (label 0), equal weights
    graph = sp.csr_matrix(([1.0, 1.0, 1.0, 1.0], ([0, 1, 0, 2], [1, 0, 2, 0])), shape=(3, 3))
    labels, fixed = np.array([-1, 2, 0]), np.array([False, True, True])
    assert harmonic_labels(graph, labels, fixed)[0] == 0
    monkeypatch.setattr(_absorb, "BLOCK_BYTES", 1)
    assert harmonic_labels(graph, labels, fixed)[0] == 0


def test_a_nearly_closed_component_is_regularised_alone() -> None:
    """Two components in one system: the well-posed one keeps the exact answer, the one
    that leaves by 1e-30 is regularised and takes the label of its heavier way out."""
    graph, labels, fixed = _well_posed(4, n=40)
    n = graph.shape[0]
    extra = sp.csr_matrix(
        ([1.0, 1.0, 1e-30, 1e-30, 3e-30, 3e-30],
         ([n, n + 1, n, n + 2, n + 1, n + 3], [n + 1, n, n + 2, n, n + 3, n + 1])),
        shape=(n + 4, n + 4),
    )  # fmt: skip
    both = (sp.block_diag([graph, sp.csr_matrix((4, 4))]) + extra).tocsr()
    all_labels = np.r_[labels, -1, -1, 0, 1]
    all_fixed = np.r_[fixed, False, False, True, True]
    laplacian, rhs, degree = _system(both, all_labels, all_fixed)
    free = np.flatnonzero(~all_fixed)
    component = (free >= n).astype(np.int64)
    got = absorbing_labels(laplacian, rhs, degree, component)
    np.testing.assert_array_equal(got.regularised, component == 1)
    small, big = component == 1, component == 0
    assert got.label[small].tolist() == [1, 1] and np.all(got.probability[small] > 0)
    ref = _dense_reference(*_system(graph, labels, fixed)[:2])
    np.testing.assert_array_equal(got.label[big], ref.argmax(axis=1))
    np.testing.assert_allclose(got.probability[big], ref.max(axis=1), rtol=0, atol=1e-9)


def test_a_failed_sum_check_is_solved_again_regularised(monkeypatch: pytest.MonkeyPatch) -> None:
    graph, labels, fixed = _well_posed(5)
    ref = _dense_reference(*_system(graph, labels, fixed)[:2])
    monkeypatch.setattr(_absorb, "SUM_TOLERANCE", -1.0)  # no exact solution passes
    got = _solve(graph, labels, fixed)
    assert got.regularised.all()
    np.testing.assert_array_equal(got.label, ref.argmax(axis=1))
    np.testing.assert_allclose(got.probability, ref.max(axis=1), rtol=1e-6)


def test_when_every_factorisation_fails_gmres_solves_it(monkeypatch: pytest.MonkeyPatch) -> None:
    graph, labels, fixed = _well_posed(6)
    ref = _dense_reference(*_system(graph, labels, fixed)[:2])

    def no_memory(*_: object, **__: object) -> None:
        raise MemoryError

    monkeypatch.setattr(_absorb, "splu", no_memory)
    got = _solve(graph, labels, fixed)
    assert got.regularised.all()
    np.testing.assert_array_equal(got.label, ref.argmax(axis=1))
    np.testing.assert_allclose(got.probability, ref.max(axis=1), rtol=1e-6)
    np.testing.assert_array_equal(harmonic_labels(graph, labels, fixed)[~fixed],
                                  ref.argmax(axis=1))  # fmt: skip


def test_when_gmres_fails_too_the_labels_stay(monkeypatch: pytest.MonkeyPatch) -> None:
    graph, labels, fixed = _well_posed(7)

    def singular(*_: object, **__: object) -> None:
        raise RuntimeError("Factor is exactly singular")

    def stalled(_: object, b: np.ndarray, **__: object) -> tuple[np.ndarray, int]:
        return np.zeros_like(b), 5

    monkeypatch.setattr(_absorb, "splu", singular)
    monkeypatch.setattr(_absorb, "gmres", stalled)
    got = _solve(graph, labels, fixed)
    assert np.all(got.label == -1) and np.all(got.probability == 0)
    np.testing.assert_array_equal(harmonic_labels(graph, labels, fixed), labels)
