"""Instance assignment on hand-built evidence: clustering, both assignment rules, propagation."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from causalsplat.field import FeatureField, FieldConfig, MaskEvidence
from causalsplat.instances import (
    InstanceConfig,
    InstanceConfigError,
    assign_instances,
    cluster_masks,
)

E1, E2 = np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])


def _unit(x: np.ndarray) -> np.ndarray:
    return x / np.linalg.norm(x, axis=1, keepdims=True)


def test_identical_features_form_one_cluster() -> None:
    labels = cluster_masks(np.tile(E1, (6, 1)), InstanceConfig())
    assert labels.tolist() == [0] * 6


def test_too_few_masks_are_all_noise_and_no_masks_is_fine() -> None:
    assert cluster_masks(np.tile(E1, (2, 1)), InstanceConfig(min_cluster_size=3)).tolist() == [
        -1,
        -1,
    ]
    assert cluster_masks(np.zeros((0, 3)), InstanceConfig()).shape == (0,)


def test_two_separated_groups_give_two_clusters() -> None:
    rng = np.random.default_rng(0)
    a = _unit(E1 + 0.02 * rng.standard_normal((5, 3)))
    b = _unit(E2 + 0.02 * rng.standard_normal((5, 3)))
    labels = cluster_masks(np.vstack([a, b]), InstanceConfig())
    assert len(set(labels[:5].tolist())) == 1 and len(set(labels[5:].tolist())) == 1
    assert labels[0] != labels[5] and labels.min() >= 0


def _scene(n_extra: int = 0) -> tuple[FeatureField, MaskEvidence, np.ndarray]:
    """Six Gaussians: 0-2 object A (masks 3-5 in views 1..3), 3-5 object B (masks 0-2).

    B's masks come first, so B becomes entity 0. Gaussian 5 is drawn a little into A's
    masks too (weight 0.2 against 1.0 in B's). Extra Gaussians are active but unseen.
    """
    n = 6 + n_extra
    feats = np.zeros((n, 3), dtype=np.float32)
    feats[:3] = E1
    feats[3:6] = E2
    mask_feats = np.vstack([np.tile(E2, (3, 1)), np.tile(E1, (3, 1))]).astype(np.float32)
    w = np.zeros((6, n))
    w[:3, 3:6] = 1.0
    w[3:, :3] = 1.0
    w[3:, 5] = 0.2
    supervised = np.zeros(n, dtype=bool)
    supervised[:6] = True
    field = FeatureField(feats, np.ones(n, dtype=bool), supervised, (), FieldConfig(feature_dim=3))
    evidence = MaskEvidence(
        view=np.array([0, 1, 2, 0, 1, 2]),
        index=np.array([0, 0, 0, 1, 1, 1]),
        pixel_weight=np.ones(6),
        features=mask_feats,
        gaussian_weight=sp.csr_matrix(w),
    )
    means = np.zeros((n, 3))
    means[:, 0] = np.arange(n, dtype=float)
    return field, evidence, means


@pytest.mark.parametrize("rule", ["vote", "feature"])
def test_both_rules_label_the_two_objects(rule: str) -> None:
    field, evidence, means = _scene()
    config = InstanceConfig(assignment=rule, min_gaussians=1)  # type: ignore[arg-type]
    out = assign_instances(field, evidence, config, means=means, scales=np.full((6, 3), 0.1))
    assert out.labels.tolist() == [1, 1, 1, 0, 0, 0]
    assert out.mask_entity.tolist() == [0, 0, 0, 1, 1, 1]
    assert out.n_entities == 2 and out.n_clusters == 2 and out.n_noise_masks == 0
    np.testing.assert_allclose(out.centers, [E2, E1], atol=1e-6)
    if rule == "vote":  # Gaussian 5 agrees with B's centre only (cosine 1 against 0)
        assert out.score[5] == 1.0


def test_vote_counts_each_view_once_and_weighs_by_feature_agreement() -> None:
    field, evidence, means = _scene()
    scales = np.full((6, 3), 0.1)
    # Gaussian 5 lies 1.0 in B's mask and 0.2 in A's mask in each of the 3 views:
    # each view votes 1/1.2 for B and 0.2/1.2 for A, summed 2.5 against 0.5.
    votes_only = InstanceConfig(min_gaussians=1, vote_feature_power=0.0)
    out = assign_instances(field, evidence, votes_only, means=means, scales=scales)
    assert out.score[5] == pytest.approx(2.5 / 3.0, rel=1e-6)
    # Feature (0.6, 0.8, 0): agreement 0.6 with A's centre, 0.8 with B's; power 1 weighs
    # the votes to 0.3 (A) and 2.0 (B), B's share 2.0 / 2.3.
    feats = field.features.copy()
    feats[5] = [0.6, 0.8, 0.0]
    mixed = FeatureField(feats, field.active, field.supervised, (), field.config)
    out = assign_instances(mixed, evidence, InstanceConfig(min_gaussians=1), means=means,
                           scales=scales)  # fmt: skip
    assert out.labels[5] == 0 and out.score[5] == pytest.approx(2.0 / 2.3, rel=1e-6)
    # One view's oversized mask does not outvote the others: Gaussian 2 (A) gets weight
    # 10 inside B's mask of view 0 (a merged mask), 1.0 in A's masks of views 1 and 2.
    w = evidence.gaussian_weight.toarray()
    w[0, 2], w[3, 2] = 10.0, 0.0
    merged = MaskEvidence(evidence.view, evidence.index, evidence.pixel_weight,
                          evidence.features, sp.csr_matrix(w))  # fmt: skip
    out = assign_instances(field, merged, votes_only, means=means, scales=scales)
    assert out.labels[2] == 1 and out.score[2] == pytest.approx(2.0 / 3.0, rel=1e-6)


def test_a_gaussian_agreeing_with_no_cluster_stays_unassigned() -> None:
    field, evidence, means = _scene()
    feats = field.features.copy()
    feats[4] = [0.0, 0.0, 1.0]  # orthogonal to both centres: every weighted vote is 0
    odd = FeatureField(feats, field.active, field.supervised, (), field.config)
    config = InstanceConfig(min_gaussians=1, min_vote_share=0.0, propagate_sigmas=0.0)
    out = assign_instances(odd, evidence, config, means=means, scales=np.full((6, 3), 0.1))
    assert out.labels[4] == -1 and out.labels[3] == 0


def test_unseen_gaussians_take_the_nearest_label_within_the_radius() -> None:
    field, evidence, means = _scene(n_extra=2)
    means[6] = [0.0, 0.25, 0.0]  # 0.25 from Gaussian 0 (A)
    means[7] = [0.0, 5.0, 0.0]  # far from everything
    scales = np.full((8, 3), 0.1)
    config = InstanceConfig(min_gaussians=1, propagate_sigmas=3.0)  # radius 0.3
    out = assign_instances(field, evidence, config, means=means, scales=scales)
    assert out.labels[6] == out.labels[0] == 1 and out.labels[7] == -1
    off = assign_instances(field, evidence, InstanceConfig(min_gaussians=1, propagate_sigmas=0),
                           means=means, scales=scales)  # fmt: skip
    assert off.labels[6] == -1


def test_pruned_gaussians_stay_unassigned_and_small_clusters_are_dropped() -> None:
    field, evidence, means = _scene()
    active = np.ones(6, dtype=bool)
    active[0] = False
    supervised = field.supervised & active
    pruned = FeatureField(field.features, active, supervised, (), field.config)
    w = evidence.gaussian_weight.toarray()
    w[:, 0] = 0.0
    ev = MaskEvidence(evidence.view, evidence.index, evidence.pixel_weight, evidence.features,
                      sp.csr_matrix(w))  # fmt: skip
    out = assign_instances(pruned, ev, InstanceConfig(min_gaussians=1), means=means,
                           scales=np.full((6, 3), 0.1))  # fmt: skip
    assert out.labels[0] == -1
    # A now owns 2 Gaussians: with min_gaussians = 3 it is dropped, its masks map to -1
    out = assign_instances(pruned, ev, InstanceConfig(min_gaussians=3), means=means,
                           scales=np.full((6, 3), 0.1))  # fmt: skip
    assert out.n_entities == 1 and out.labels.tolist() == [-1, -1, -1, 0, 0, 0]
    assert out.mask_entity.tolist() == [0, 0, 0, -1, -1, -1]


def test_no_masks_give_no_entities() -> None:
    field, _, means = _scene()
    empty = MaskEvidence(np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0),
                         np.zeros((0, 3), np.float32), sp.csr_matrix((0, 6)))  # fmt: skip
    out = assign_instances(field, empty, InstanceConfig(), means=means, scales=np.ones((6, 3)))
    assert out.n_entities == 0 and np.all(out.labels == -1)


@pytest.mark.parametrize(
    ("name", "value"),
    [("min_cluster_size", 1), ("min_samples", 0), ("selection", "max"),
     ("selection_epsilon", -0.1), ("assignment", "nearest"), ("min_similarity", 2.0),
     ("min_vote_share", 1.5), ("vote_feature_power", -1.0), ("min_gaussians", 0),
     ("propagate_sigmas", float("inf")), ("min_evidence", -0.5), ("min_evidence", float("nan")),
     ("propagate_neighbors", 0), ("propagate_neighbors", 2.5), ("propagate_coplanar", 1)],
)  # fmt: skip
def test_instance_config_rejects_out_of_range_values(name: str, value: object) -> None:
    with pytest.raises(InstanceConfigError, match=f"InstanceConfig.{name}"):
        InstanceConfig(**{name: value})  # type: ignore[arg-type]


def _dense_reference_labels(
    evidence: MaskEvidence, cluster: np.ndarray, centers: np.ndarray, feats: np.ndarray,
    power: float, config: InstanceConfig,
) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """Step 3 with a dense (N, K) vote matrix, the way it was first written."""
    n, k = evidence.gaussian_weight.shape[1], centers.shape[0]
    coo = evidence.gaussian_weight.tocoo()
    keep = (cluster[coo.row] >= 0) & (coo.data > 0)
    mask, gauss, weight = coo.row[keep], coo.col[keep], coo.data[keep]
    _, view = np.unique(evidence.view, return_inverse=True)
    _, pair = np.unique(gauss * (view.max() + 1) + view[mask], return_inverse=True)
    share = weight / np.bincount(pair, weights=weight)[pair]
    votes = sp.csr_matrix((share, (gauss, cluster[mask])), shape=(n, k)).toarray()
    rows = np.flatnonzero(votes.sum(axis=1) > 0)
    votes = votes[rows] * np.clip(feats[rows].astype(np.float64) @ centers.T, 0, None) ** power
    labels, best = np.full(n, -1), np.zeros(n)
    kept = np.arange(k)
    while True:
        sub = votes[:, kept]
        total = sub.sum(axis=1, keepdims=True)
        sub = np.divide(sub, total, out=np.zeros_like(sub), where=total > 0)
        arg = sub.argmax(axis=1)
        value = sub[np.arange(rows.size), arg]
        ok = (value >= config.min_vote_share) & (value > 0)
        small = np.bincount(arg[ok], minlength=kept.size) < config.min_gaussians
        if not small.any():
            break
        kept = kept[~small]
    labels[rows[ok]] = kept[arg[ok]]
    best[rows[ok]] = value[ok]
    return labels, best


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_sparse_votes_match_a_dense_vote_matrix(seed: int) -> None:
    """The sparse vote accumulation takes the decisions of the dense (N, K) one, cluster
    dropping included, on random evidence with ties and all-zero agreements."""
    from causalsplat.instances.assign import _assign, _view_votes, _with_agreement

    rng = np.random.default_rng(seed)
    n, m, k, dim = 400, 60, 7, 5
    w = sp.random(m, n, density=0.08, random_state=seed, format="csr") * 3.0
    w.data[rng.random(w.nnz) < 0.2] = 1.0  # equal weights: ties between clusters
    evidence = MaskEvidence(
        view=np.sort(rng.integers(0, 6, m)), index=np.arange(m), pixel_weight=np.ones(m),
        features=np.zeros((m, dim), np.float32), gaussian_weight=w,
    )  # fmt: skip
    cluster = rng.integers(-1, k, m)
    centers = _unit(rng.standard_normal((k, dim)))
    feats = _unit(rng.standard_normal((n, dim))).astype(np.float32)
    feats[:20] = 0.0  # no agreement with any cluster
    config = InstanceConfig(min_gaussians=12, min_vote_share=0.3)
    for power in (0.0, 1.0):
        votes, rows = _view_votes(evidence, cluster, k)
        scores = _with_agreement(votes, rows, centers, feats, power)
        assert sp.issparse(scores) and scores.nnz < rows.size * k
        labels, best, _ = _assign(n, scores, rows, config)
        ref_labels, ref_best = _dense_reference_labels(
            evidence, cluster, centers, feats, power, config
        )
        np.testing.assert_array_equal(labels, ref_labels)
        np.testing.assert_allclose(best, ref_best, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("seed", range(6))
def test_row_argmax_of_sparse_scores_is_the_dense_argmax(seed: int) -> None:
    """First column of the row maximum, ties, empty rows and rows of stored zeros included."""
    from causalsplat.instances._sparse import csr_row_argmax

    rng = np.random.default_rng(seed)
    dense = rng.integers(0, 4, (50, 9)).astype(np.float64) / 3.0  # many ties and zeros
    dense[rng.random(50) < 0.2] = 0.0
    m = sp.csr_matrix(dense)
    zero_row = int(np.flatnonzero(np.diff(m.indptr) > 0)[0])
    m.data[m.indptr[zero_row] : m.indptr[zero_row + 1]] = 0.0  # a row of stored zeros
    dense[zero_row] = 0.0
    m.sort_indices()
    best, value = csr_row_argmax(m)
    np.testing.assert_array_equal(best, dense.argmax(axis=1))
    np.testing.assert_array_equal(value, dense.max(axis=1))
