"""Harmonic labels on graphs that are hard to solve: duplicates, near-closed components,
zero weights, extreme scales, and Gaussians copied many times over (densified scenes)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from causalsplat.bench._densify import densify_centres
from causalsplat.instances.propagate import harmonic_labels, surface_graph
from causalsplat.synth._gaussians import sample_gaussians
from causalsplat.synth.config import SynthConfig
from causalsplat.synth.generate import generate_layout, stream


def _graph(n: int, edges: list[tuple[int, int, float]]) -> sp.csr_matrix:
    """Symmetric (n, n) weights from ``(i, j, w)`` triples."""
    i, j, w = (np.array(c) for c in zip(*edges, strict=True))
    return sp.csr_matrix((np.r_[w, w], (np.r_[i, j], np.r_[j, i])), shape=(n, n))


@pytest.fixture(scope="module")
def synth_gaussians() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Centres, scales (standard deviations), quaternions and GT entity of the tiny scene."""
    config = SynthConfig.preset("tiny", seed=0)
    sampled = sample_gaussians(generate_layout(config, stream(0, "layout")), config,
                               stream(0, "gaussians"))  # fmt: skip
    scene = sampled.scene
    return (scene.means.astype(np.float64), np.exp(scene.log_scales.astype(np.float64)),
            scene.quats.astype(np.float64), sampled.labels.astype(np.int64))  # fmt: skip


@pytest.mark.parametrize(("copies", "jitter"), [(4, 0.05), (16, 0.0), (16, 1e-3), (16, 0.05)])
def test_densified_scenes_propagate_like_the_original(
    synth_gaussians: tuple[np.ndarray, ...], copies: int, jitter: float
) -> None:
    """Copies of a Gaussian share its fate: 60 % of the originals are well seen (all their
    copies fixed to the GT entity), the others take labels along the surface graph. Around
    each original the copies form a nearly closed cluster (its edges to other Gaussians
    weigh as little as 1e-100): the solve must neither raise nor return noise. With more
    copies than neighbours (16), a cluster may have no edge out at all: it keeps -1."""
    means, scales, quats, gt = synth_gaussians
    seen = np.random.default_rng(1).random(means.shape[0]) < 0.6
    dense, origin = densify_centres(means, scales, copies, jitter)
    radius = 3.0 * float(np.median(scales.max(axis=1)))  # the default of assign_instances
    graph = surface_graph(dense, scales[origin], quats[origin], k=16, radius=radius)
    fixed = seen[origin]
    out = harmonic_labels(graph, np.where(fixed, gt[origin], -1), fixed)
    assert np.array_equal(out[fixed], gt[origin][fixed])
    n_comp, comp = connected_components(graph, directed=False)
    holds_fixed = np.zeros(n_comp, dtype=bool)
    holds_fixed[comp[fixed]] = True
    reach, cut_off = holds_fixed[comp] & ~fixed, ~holds_fixed[comp]
    assert reach.sum() > 30 and np.all(out[cut_off] == -1)
    assert (out[reach] >= 0).mean() > 0.99
    labelled = reach & (out >= 0)
    assert (out[labelled] == gt[origin][labelled]).mean() > 0.85


def test_duplicate_centres_take_the_label_of_their_fixed_twin() -> None:
    # two stacks of three identical centres, 1 apart: one fixed Gaussian in each stack
    means = np.repeat(np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]), 3, axis=0)
    graph = surface_graph(means, np.full((6, 3), 0.5), None, k=5, radius=2.0)
    assert np.all(np.isfinite(graph.data)) and np.all(graph.data > 0)
    labels = np.array([4, -1, -1, 7, -1, -1])
    fixed = labels >= 0
    assert harmonic_labels(graph, labels, fixed).tolist() == [4, 4, 4, 7, 7, 7]


def test_a_component_that_reaches_a_fixed_node_only_by_a_vanishing_weight() -> None:
    """Free 0-1 (weight 1) reaches fixed 2 (label 5) by 1e-20: ``1 + 1e-20 == 1``, so the
    block of 0 and 1 is exactly singular in floating point. The walk from 0 or 1 still ends
    at 2, surely: both take 5. Free 3-4 (weight 1) leaves by 1e-20 to fixed 5 (label 0) and
    by 3e-20 to fixed 6 (label 1): the walk mixes long before it leaves, so both nodes take
    the label with the heavier way out, 1. Node 7 next to fixed 8 is well posed."""
    graph = _graph(9, [(0, 1, 1.0), (1, 2, 1e-20), (3, 4, 1.0), (3, 5, 1e-20), (4, 6, 3e-20),
                       (7, 8, 0.5)])  # fmt: skip
    labels = np.array([-1, -1, 5, -1, -1, 0, 1, -1, 2])
    fixed = labels >= 0
    assert harmonic_labels(graph, labels, fixed).tolist() == [5, 5, 5, 1, 1, 0, 1, 2, 2]


def test_a_nearly_closed_part_inside_a_well_posed_component() -> None:
    """Fixed 0 (label 3) - 1 - 2 - 3 with weights 1, 1e-30, 1: the component leaves well
    enough as a whole, but the block of 2 and 3 is singular in floating point."""
    graph = _graph(4, [(0, 1, 1.0), (1, 2, 1e-30), (2, 3, 1.0)])
    labels = np.array([3, -1, -1, -1])
    assert harmonic_labels(graph, labels, labels >= 0).tolist() == [3, 3, 3, 3]


@pytest.mark.parametrize("leak", [1e-9, 1e-12, 1e-14, 1e-200])
def test_nearly_closed_components_follow_the_heavier_way_out(leak: float) -> None:
    """A chain 0-1-2-3 (weights 1) leaves by ``leak`` at node 0 to label 0 and by
    ``2 * leak`` at node 3 to label 1: every node takes 1 when ``leak`` is tiny."""
    graph = _graph(6, [(0, 1, 1.0), (1, 2, 1.0), (2, 3, 1.0), (0, 4, leak), (3, 5, 2 * leak)])
    labels = np.array([-1, -1, -1, -1, 0, 1])
    assert harmonic_labels(graph, labels, labels >= 0).tolist() == [1, 1, 1, 1, 0, 1]


def test_isolated_and_unfixed_components_keep_their_labels() -> None:
    # 0 isolated free, 1 isolated fixed, 2-3 a free pair with no fixed node, 4-5 well posed
    graph = _graph(6, [(2, 3, 1.0), (4, 5, 1.0)])
    labels = np.array([3, 1, -1, 6, 2, -1])
    fixed = np.array([False, True, False, False, True, False])
    assert harmonic_labels(graph, labels, fixed).tolist() == [3, 1, -1, 6, 2, 2]


def test_zero_and_invalid_weights_are_no_edges() -> None:
    """Stored zeros (exp underflow), NaN and negative weights join nothing: free 0 is
    joined to free 1 only by them and keeps its label; 1 takes its fixed neighbour's."""
    # duplicate (row, col) entries are summed by csr_matrix: add the bad edge separately
    parts = [sp.csr_matrix(([w, w], ([0, 1], [1, 0])), shape=(3, 3))
             for w in (0.0, np.nan, -1.0, np.inf)]  # fmt: skip
    graph = sp.csr_matrix(([0.0, 0.0, 0.5, 0.5], ([0, 1, 1, 2], [1, 0, 2, 1])), shape=(3, 3))
    labels = np.array([7, -1, 3])
    fixed = labels == 3
    assert graph.nnz == 4  # the zeros are stored
    assert harmonic_labels(graph, labels, fixed).tolist() == [7, 3, 3]
    for part in parts:
        weird = (part + sp.csr_matrix(([0.5, 0.5], ([1, 2], [2, 1])), shape=(3, 3))).tocsr()
        assert harmonic_labels(weird, labels, fixed).tolist() == [7, 3, 3]
    zero = sp.csr_matrix((np.zeros(4), ([0, 1, 1, 2], [1, 0, 2, 1])), shape=(3, 3))
    assert harmonic_labels(zero, labels, fixed).tolist() == [7, -1, 3]


def test_far_apart_gaussians_underflow_to_no_edge() -> None:
    # two rows of five centres 1e-3 apart, 1 apart from each other: the median neighbour
    # distance is 2e-3, so an edge across the gap weighs exp(-(1 / 2e-3)**2) = 0
    row = np.c_[np.arange(5) * 1e-3, np.zeros((5, 2))]
    means = np.vstack([row, row + np.array([1.0, 0.0, 0.0])])
    graph = surface_graph(means, np.full((10, 3), 0.1), None, k=5, radius=2.0)
    assert np.all(graph.data > 0) and graph[:5, 5:].nnz == 0 and graph[:5, :5].nnz == 20
    labels = np.array([1, -1, -1, -1, -1, 2, -1, -1, -1, -1])
    assert harmonic_labels(graph, labels, labels >= 0).tolist() == [1] * 5 + [2] * 5


@pytest.mark.parametrize("unit", [1e-8, 1e8])
def test_tiny_and_huge_scenes_give_the_same_graph_and_labels(
    synth_gaussians: tuple[np.ndarray, ...], unit: float
) -> None:
    means, scales, quats, gt = synth_gaussians
    dense, origin = densify_centres(means[:800], scales[:800], 4, 0.05)
    s, q = scales[origin], quats[origin]
    radius = 3.0 * float(np.median(s.max(axis=1)))
    ref = surface_graph(dense, s, q, k=16, radius=radius)
    scaled = surface_graph(dense * unit, s * unit, q, k=16, radius=radius * unit)
    assert np.all(np.isfinite(scaled.data)) and np.all(scaled.data > 0)
    assert (scaled != scaled.T).nnz == 0
    np.testing.assert_allclose(scaled.toarray(), ref.toarray(), rtol=1e-9, atol=1e-300)
    fixed = np.random.default_rng(2).random(800)[origin] < 0.5
    labels = np.where(fixed, gt[origin], -1)
    expected = harmonic_labels(ref, labels, fixed)
    np.testing.assert_array_equal(harmonic_labels(scaled, labels, fixed), expected)
    # a graph whose weights are all scaled by 1e-100 or 1e100 gives the same labels
    assert ref.data.min() * 1e-100 > 1e-300  # (no weight underflows)
    for factor in (1e-100, 1e100):
        np.testing.assert_array_equal(harmonic_labels(ref * factor, labels, fixed), expected)
