"""Votes smoothed along surfaces: against a direct float64 solve, by hand, degenerate."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse.linalg import spsolve

from causalsplat.instances import InstanceConfig, InstanceConfigError, smooth
from causalsplat.instances.propagate import surface_graph
from causalsplat.instances.smooth import smoothed_labels, smoothed_shares


def _scene(seed: int, n: int = 300, k: int = 4) -> tuple[sp.csr_matrix, sp.csr_matrix, np.ndarray]:
    rng = np.random.default_rng(seed)
    means = rng.uniform(0, 1, (n, 3)) * [1, 1, 0.1]
    graph = surface_graph(means, np.full((n, 3), 0.02), None, k=8, radius=0.3)
    votes = rng.random((n, k)) * (rng.random((n, k)) < 0.5)
    votes[rng.random(n) < 0.1] = 0.0  # some nodes did not vote
    total = votes.sum(axis=1, keepdims=True)
    shares = np.divide(votes, total, out=np.zeros_like(votes), where=total > 0)
    return graph, sp.csr_matrix(shares), rng.uniform(0, 5, n)


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("smoothing", [0.5, 10.0, 100.0])
def test_smoothed_shares_solve_the_system_in_float64(
    seed: int, smoothing: float, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(smooth, "TOLERANCE", 1e-10)
    monkeypatch.setattr(smooth, "PRUNE", 0.0)
    monkeypatch.setattr(smooth, "MAX_ITERATIONS", 20_000)
    graph, shares, conf = _scene(seed)
    w = graph.toarray()
    d = w.sum(axis=1)
    lam = np.minimum(conf, smooth.CONFIDENCE_CAP) * np.where(d > 0, d, 1.0) / smoothing
    exact = spsolve(sp.csc_matrix(np.diag(d + lam) - w), np.diag(lam) @ shares.toarray())
    got = smoothed_shares(graph, shares, conf, smoothing).toarray()
    np.testing.assert_allclose(got, exact, atol=1e-9)
    # and the labels at the default tolerance are those of the exact solve where it is
    # clear (confidences as the build's well-seen Gaussians have, >= 0.5)
    monkeypatch.undo()
    if smoothing > 10:
        return
    conf = np.maximum(conf, 0.5)
    lam = np.minimum(conf, smooth.CONFIDENCE_CAP) * np.where(d > 0, d, 1.0) / smoothing
    exact = spsolve(sp.csc_matrix(np.diag(d + lam) - w), np.diag(lam) @ shares.toarray())
    labels = smoothed_labels(graph, shares, conf, smoothing)
    top2 = np.sort(exact, axis=1)[:, -2:]
    clear = top2[:, 1] - top2[:, 0] > 0.02
    assert clear.sum() >= 50
    np.testing.assert_array_equal(labels[clear], exact.argmax(axis=1)[clear])


def test_accelerated_iterations_reach_the_tolerance_on_a_stiff_system(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # a path of 400 nodes at smoothing 100: the contraction is 100/101, and plain Jacobi
    # iterations are still 0.03 from the solution after 100 steps; Chebyshev's are not
    monkeypatch.setattr(smooth, "MAX_ITERATIONS", 100)
    monkeypatch.setattr(smooth, "PRUNE", 0.0)
    n = 400
    path = sp.diags([np.ones(n - 1), np.ones(n - 1)], [-1, 1], shape=(n, n)).tocsr()
    votes = np.zeros((n, 2))
    votes[: n // 2, 0] = votes[n // 2 :, 1] = 1.0
    votes[::7] = votes[::7, ::-1]  # every seventh votes the other way
    w = path.toarray()
    d = w.sum(axis=1)
    exact = spsolve(sp.csc_matrix(np.diag(d + d / 100) - w), np.diag(d / 100) @ votes)
    got = smoothed_shares(path, sp.csr_matrix(votes), np.ones(n), 100.0).toarray()
    assert np.abs(got - exact).max() <= smooth.TOLERANCE


def test_a_patch_of_wrong_votes_goes_to_its_surface_and_a_small_surface_keeps_its_own() -> None:
    # a 20 x 20 floor voting 0 with a 2 x 2 patch voting 1 in it; a 3 x 3 box beside it,
    # joined to the floor by weak edges, voting 2 as one
    floor = np.array([[x, y, 0.0] for x in range(20) for y in range(20)])
    box = np.array([[x, y, 1.0] for x in range(30, 33) for y in range(3)])
    means = np.vstack([floor, box])
    n = len(means)
    graph = sp.lil_matrix(surface_graph(means, np.full((n, 3), 0.5), None, k=8, radius=1.5))
    graph[399, 400] = graph[400, 399] = 1e-3  # a floor corner touches the box, barely
    votes = np.zeros((n, 3))
    votes[:400, 0] = 1.0
    patch = [i for i, p in enumerate(floor.tolist()) if 8 <= p[0] <= 9 and 8 <= p[1] <= 9]
    votes[patch] = [0.0, 1.0, 0.0]
    votes[400:, 2] = 1.0
    labels = smoothed_labels(graph.tocsr(), sp.csr_matrix(votes), np.ones(n), 10.0)
    assert labels[:400].tolist() == [0] * 400
    assert labels[400:].tolist() == [2] * 9


def test_degenerate_inputs() -> None:
    votes = sp.csr_matrix(np.array([[0.0, 1.0], [0.0, 0.0], [1.0, 0.0]]))
    no_edges = sp.csr_matrix((3, 3))
    # without edges each keeps its own vote, and a node without one gets none
    assert smoothed_labels(no_edges, votes, np.ones(3), 10.0).tolist() == [1, -1, 0]
    # tiny and huge weights give the same labels as ordinary ones (rescaled exactly)
    graph, shares, conf = _scene(7)
    ref = smoothed_labels(graph, shares, conf, 10.0)
    for scale in (1e-300, 1e300):
        np.testing.assert_array_equal(smoothed_labels(graph * scale, shares, conf, 10.0), ref)
    bad = graph.copy()
    bad.data[:5] = [np.nan, np.inf, -1.0, 0.0, np.nan]  # no edges, not errors
    assert smoothed_labels(bad, shares, conf, 10.0).shape == (300,)
    with pytest.raises(ValueError, match="smoothing must be > 0"):
        smoothed_labels(graph, shares, conf, 0.0)
    with pytest.raises(ValueError, match="shares has 2 rows for a graph of 3 nodes"):
        smoothed_labels(no_edges, votes[:2], np.ones(3), 1.0)


def test_vote_smoothing_is_checked() -> None:
    with pytest.raises(InstanceConfigError, match="vote_smoothing"):
        InstanceConfig(vote_smoothing=-1.0)
    assert InstanceConfig(vote_smoothing=0.0).vote_smoothing == 0.0
