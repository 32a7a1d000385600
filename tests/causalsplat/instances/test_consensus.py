"""Multi-view consensus (``instances/consensus.py``): clusters of masks that draw the same
Gaussians, with features alike, are merged; neighbours that only share a border are not."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from causalsplat.instances import InstanceConfig, InstanceConfigError
from causalsplat.instances.consensus import merged_clusters, overlaps


def _reference_overlaps(votes: np.ndarray) -> np.ndarray:
    k = votes.shape[1]
    total = votes.sum(axis=0)
    out = np.zeros((k, k))
    for a in range(k):
        for b in range(k):
            small = min(total[a], total[b])
            out[a, b] = np.minimum(votes[:, a], votes[:, b]).sum() / small if small > 0 else 0.0
    return out


@pytest.mark.parametrize("seed", range(12))
def test_overlaps_against_a_dense_reference(seed: int) -> None:
    rng = np.random.default_rng(seed)
    dense = rng.random((int(rng.integers(1, 40)), int(rng.integers(1, 9))))
    dense[rng.random(dense.shape) < 0.6] = 0.0
    got = overlaps(sp.csr_matrix(dense))
    want = _reference_overlaps(dense)
    assert np.allclose(got, want, atol=1e-12)


def test_one_object_seen_from_two_sides_is_merged_and_neighbours_are_not() -> None:
    # Gaussians 0-9: one object whose masks fell into clusters 0 (front views) and 1
    # (back views); 10-19: its neighbour (cluster 2), sharing two border Gaussians
    votes = np.zeros((20, 3))
    votes[:10, 0] = 3.0
    votes[2:10, 1] = 2.0
    votes[10:, 2] = 4.0
    votes[8:10, 2] = 1.0
    cluster = np.array([0, 0, 1, 1, 2, 2, -1])
    merged = merged_clusters(cluster, sp.csr_matrix(votes), 0.4)
    assert merged.tolist() == [0, 0, 0, 0, 1, 1, -1]
    # features that disagree keep them apart, whatever the overlap
    apart = np.ones((3, 3), dtype=bool)
    apart[0, 1] = apart[1, 0] = False
    assert merged_clusters(cluster, sp.csr_matrix(votes), 0.4, apart).tolist() == [
        0, 0, 1, 1, 2, 2, -1
    ]  # fmt: skip


def test_merging_is_a_checked_option() -> None:
    assert InstanceConfig().merge_overlap == 0.4 and InstanceConfig().merge_cosine == 0.4
    with pytest.raises(InstanceConfigError, match=r"merge_overlap must be in \[0, 1\]"):
        InstanceConfig(merge_overlap=1.5)
    with pytest.raises(InstanceConfigError, match="merge_cosine"):
        InstanceConfig(merge_cosine=2.0)
