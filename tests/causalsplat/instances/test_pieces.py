"""One object, one piece (``instances/pieces.py``): entities whose Gaussians lie in
far-apart pieces are split where their masks say; the floor and the ceiling never are."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from causalsplat.field import FeatureField, FieldConfig, MaskEvidence
from causalsplat.instances import InstanceConfig, InstanceConfigError, assign_instances
from causalsplat.instances.pieces import pieces, split_pieces


def _reference_pieces(points: np.ndarray, gap: float) -> np.ndarray:
    """Cells of side ``gap`` from the points' minimum, joined when their integer
    coordinates differ by at most one on every axis: a dense all-pairs reference."""
    cell = np.floor((points - points.min(axis=0)) / gap).astype(np.int64)
    near = np.abs(cell[:, None, :] - cell[None, :, :]).max(axis=2) <= 1
    return connected_components(sp.csr_matrix(near), directed=False)[1]


@pytest.mark.parametrize("seed", range(10))
def test_pieces_against_a_dense_reference(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 120))
    points = rng.random((n, 3)) * rng.choice([1.0, 5.0, 1e3]) - rng.random() * 1e2
    gap = float(rng.choice([0.05, 0.2, 1.0])) * float(np.ptp(points) or 1.0)
    got, want = pieces(points, gap), _reference_pieces(points, gap)
    # the same partition (numbering aside)
    assert (got[:, None] == got[None, :]).tolist() == (want[:, None] == want[None, :]).tolist()
    # points closer than the gap always share a piece
    close = np.linalg.norm(points[:, None] - points[None, :], axis=2) < gap
    assert (got[:, None] == got[None, :])[close].all()


def test_small_pieces_and_pieces_no_mask_chose_stay_and_kept_entities_are_not_split() -> None:
    # entity 0: a main piece (0-5), a far piece (6-8) one mask chose, a stray Gaussian (9)
    means = np.array([[x * 0.01, 0, 0] for x in range(6)] + [[5.0, 0, 0], [5.01, 0, 0],
                     [5.02, 0, 0], [9.0, 0, 0]])  # fmt: skip
    w = np.zeros((3, 10))
    w[0, :6] = w[1, :6] = 1.0
    w[2, 6:9] = 1.0
    labels, masks = split_pieces(np.zeros(10, int), np.zeros(3, int), sp.csr_matrix(w), means,
                                 gap=0.1, min_share=0.2, min_gaussians=2)  # fmt: skip
    assert labels.tolist() == [0] * 6 + [1] * 3 + [0] and masks.tolist() == [0, 0, 1]
    # the far piece is there, but every mask draws the main one: no split
    w[2] = 0.0
    w[2, :6] = 1.0
    labels, masks = split_pieces(np.zeros(10, int), np.zeros(3, int), sp.csr_matrix(w), means,
                                 gap=0.1, min_share=0.2, min_gaussians=2)  # fmt: skip
    assert labels.tolist() == [0] * 10 and masks.tolist() == [0, 0, 0]
    w[2] = 0.0
    w[2, 6:9] = 1.0
    kept = split_pieces(np.zeros(10, int), np.zeros(3, int), sp.csr_matrix(w), means, gap=0.1,
                        min_share=0.2, min_gaussians=2, keep={0})  # fmt: skip
    assert kept[0].tolist() == [0] * 10


def _one_cluster_two_places(label: str) -> tuple[FeatureField, MaskEvidence, np.ndarray, list]:
    """A box (Gaussians 0-5, masks in views 0-3) and a window 3 m away (6-9, masks in
    views 4-6) whose masks' features equal the box's: HDBSCAN makes them one cluster."""
    n = 10
    means = np.array([[x * 0.05, 0, 0] for x in range(6)] + [[3 + x * 0.05, 0, 0]
                     for x in range(4)])  # fmt: skip
    e1 = np.eye(3)[0]
    rows = []
    for view in range(7):
        w = np.zeros(n)
        if view < 4:
            w[:6] = 1.0
        else:
            w[6:] = 1.0
        rows.append(w)
    field = FeatureField(np.tile(e1, (n, 1)).astype(np.float32), np.ones(n, bool),
                         np.ones(n, bool), (), FieldConfig(feature_dim=3))  # fmt: skip
    evidence = MaskEvidence(view=np.arange(7), index=np.zeros(7, int), pixel_weight=np.ones(7),
                            features=np.tile(e1, (7, 1)).astype(np.float32),
                            gaussian_weight=sp.csr_matrix(np.array(rows)))  # fmt: skip
    return field, evidence, means, ["box"] * 4 + [label] * 3


def test_an_entity_in_two_places_becomes_two_labelled_by_their_own_masks() -> None:
    field, evidence, means, labels = _one_cluster_two_places("window")
    config = InstanceConfig(min_gaussians=1)
    scales = np.full((10, 3), 0.02)
    out = assign_instances(field, evidence, config, means=means, scales=scales, mask_labels=labels)
    assert out.labels.tolist() == [0] * 6 + [1] * 4
    assert out.mask_entity.tolist() == [0] * 4 + [1] * 3 and out.n_entities == 2
    assert np.allclose(np.linalg.norm(out.centers, axis=1), 1.0)
    off = InstanceConfig(min_gaussians=1, split_gap=0.0)
    whole = assign_instances(field, evidence, off, means=means, scales=scales, mask_labels=labels)
    assert whole.labels.tolist() == [0] * 10
    # a ceiling seen in two far patches stays one
    field, evidence, means, labels = _one_cluster_two_places("ceiling")
    labels = ["ceiling"] * 7
    out = assign_instances(field, evidence, config, means=means, scales=scales, mask_labels=labels)
    assert out.labels.tolist() == [0] * 10


def test_the_gap_is_a_checked_option() -> None:
    assert InstanceConfig().split_gap == 20.0
    with pytest.raises(InstanceConfigError, match=r"split_gap must be in \[0, inf"):
        InstanceConfig(split_gap=-1.0)
