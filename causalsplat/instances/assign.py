"""3D instances from mask features: HDBSCAN clusters, cluster centres, an entity per Gaussian.

1. Every usable mask of every view has a feature ``p`` (unit vector, see
   :func:`causalsplat.field.mask_evidence`). HDBSCAN clusters them (Euclidean
   distance between unit vectors, a monotone function of the cosine); noise masks get -1.
   When HDBSCAN finds no cluster at all (for instance when every mask feature is the
   same, one object seen many times) it is run again allowing a single cluster.
2. Each cluster ``k`` has the centre ``C_k = Norm(mean of its mask features)``. Clusters
   whose masks draw the same Gaussians from different views and whose centres agree are
   merged (multi-view consensus, :mod:`causalsplat.instances.consensus`); so are the
   clusters most of whose masks are labelled as the floor, or as the ceiling, when the
   masks carry labels (:mod:`causalsplat.instances.structures`); and the centres are
   taken again.
3. Each supervised Gaussian takes ``argmax_k f·C_k`` (``assignment="feature"``, the
   method's rule) or, by default (``assignment="vote"``), the cluster its views vote for:
   every view in which the Gaussian is drawn inside clustered masks casts one vote, split
   among the clusters in proportion to the blending weight the Gaussian carries inside
   each one's masks there; the votes are summed over those views, weighted by the
   feature agreement ``max(0, f·C_k) ** vote_feature_power`` and normalised to shares.
   One vote per view keeps a single view's oversized (merged) mask from outvoting the
   other views; the feature agreement breaks the remaining ties in favour of what the
   field learned from all views. The winner is accepted when its score reaches
   ``min_similarity`` (feature) or ``min_vote_share`` (vote); clusters that win
   fewer than ``min_gaussians`` Gaussians are dropped and their Gaussians re-assigned
   among the rest.
4. On the surface graph (edges at most ``propagate_sigmas`` median scales long,
   weighted by how well the two Gaussians lie in one plane, by the agreement of their
   features and by how alike their colours are; see
   :mod:`causalsplat.instances.propagate`), the well-seen Gaussians' votes
   are first smoothed (``vote_smoothing``, :mod:`causalsplat.instances.smooth`: a patch
   of wrong votes goes to the surface around it). Then weakly seen Gaussians (evidence
   below ``min_evidence`` times the median: seen mostly through an occluder, whose masks
   they vote for) and active Gaussians still unassigned take their entity from the
   well-seen ones along the graph.
   Those the graph does not connect to any well-seen Gaussian (or connects by weights too
   small to carry a probability) keep their vote, or stay -1; pruned Gaussians stay -1.
5. An entity whose Gaussians lie in pieces more than ``split_gap`` median Gaussian sizes
   apart is split where its masks say (:mod:`causalsplat.instances.pieces`): no object is
   two pieces metres apart, but the few masks of a window can join the cluster of a box
   across the room. The floor and the ceiling are never split.
Entity ids are 0..K-1 in the order of each entity's first mask (view order, then mask
order), so they do not depend on HDBSCAN's label numbering.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse as sp

from causalsplat.errors import MissingDependencyError
from causalsplat.field.types import FeatureField, MaskEvidence
from causalsplat.field.weights import normalize_rows
from causalsplat.instances._ids import by_first_appearance
from causalsplat.instances._sparse import csr_row_argmax, csr_row_shares
from causalsplat.instances.config import InstanceConfig
from causalsplat.instances.consensus import joined_clusters, overlaps
from causalsplat.instances.pieces import split_pieces
from causalsplat.instances.propagate import (
    colour_weighted,
    feature_weighted,
    harmonic_labels,
    surface_graph,
)
from causalsplat.instances.smooth import smoothed_labels
from causalsplat.instances.structures import cluster_labels, structure_pairs

#: A piece of an entity must hold this share of its Gaussians to become an entity of its
#: own (step 5): a few stray Gaussians are no object.
PIECE_SHARE = 0.2


@dataclass(frozen=True, slots=True, eq=False)
class InstanceAssignment:
    """The 3D instances of a scene.

    Attributes:
        labels: (N,) int64 entity id per Gaussian, -1 unassigned.
        mask_entity: (M,) int64 entity of each usable mask (rows of the
            :class:`~causalsplat.field.MaskEvidence`; -1: noise, or its cluster was dropped).
        centers: (K, C) float32 unit cluster centres ``C_k``, row ``k`` = entity ``k``.
        score: (N,) float32 the assignment score of each Gaussian (a cosine or a vote
            share; 0 when unassigned, or when step 4 gave it another entity).
        n_clusters: clusters HDBSCAN found (before dropping small ones).
        n_noise_masks: masks HDBSCAN left as noise.
    """

    labels: np.ndarray
    mask_entity: np.ndarray
    centers: np.ndarray
    score: np.ndarray
    n_clusters: int
    n_noise_masks: int

    @property
    def n_entities(self) -> int:
        return int(self.centers.shape[0])


def cluster_masks(features: np.ndarray, config: InstanceConfig) -> np.ndarray:
    """(M,) int64 HDBSCAN cluster of each (M, C) mask feature, -1 noise (step 1).

    The clusters are the ``hdbscan`` package's (McInnes, Healy and Astels), on its exact
    minimum spanning tree (``approx_min_span_tree=False``), so a run does not depend on
    the order the approximate tree visits ties in. ``min_samples`` is capped at ``M - 1``.
    """
    x = np.asarray(features, dtype=np.float64)
    if x.shape[0] < config.min_cluster_size:
        return np.full(x.shape[0], -1, dtype=np.int64)
    hdbscan = _hdbscan()
    min_samples = config.min_samples or config.min_cluster_size

    def run(single: bool) -> np.ndarray:
        model = hdbscan.HDBSCAN(
            min_cluster_size=config.min_cluster_size,
            min_samples=min(min_samples, x.shape[0] - 1),
            metric="euclidean",
            cluster_selection_method=config.selection,
            cluster_selection_epsilon=config.selection_epsilon,
            allow_single_cluster=single,
            approx_min_span_tree=False,
            core_dist_n_jobs=1,
        )
        return np.asarray(model.fit(x).labels_, dtype=np.int64)

    labels = run(False)
    if labels.size and labels.max() < 0:
        labels = run(True)
    return labels


def _hdbscan() -> Any:
    """The ``hdbscan`` package, imported when the instance stage first clusters."""
    try:
        import hdbscan
    except ImportError as exc:  # pragma: no cover - the field extra installs it
        raise MissingDependencyError(
            "clustering masks into entities needs hdbscan: pip install 'causalsplat[build]'"
        ) from exc
    return hdbscan


def assign_instances(
    field: FeatureField,
    evidence: MaskEvidence,
    config: InstanceConfig,
    *,
    means: np.ndarray,
    scales: np.ndarray,
    quats: np.ndarray | None = None,
    mask_labels: Sequence[str | None] | None = None,
    mask_clusters: np.ndarray | None = None,
    colors: np.ndarray | None = None,
) -> InstanceAssignment:
    """Cluster the masks and give every Gaussian an entity (module docstring).

    ``means`` (N, 3), ``scales`` (N, 3) and ``quats`` (N, 4, wxyz) of the scene build the
    surface graph of step 4; without ``quats`` its edges weigh distance only, without
    ``colors`` ((N, 3) sRGB in [0, 1], the Gaussians' base colours) not colour.
    ``mask_labels`` (M,): each usable mask's label (``None`` where it has none), for
    ``InstanceConfig.merge_structures``; without them no cluster is joined by its label.
    ``mask_clusters`` (M,): a cluster per usable mask (integers, -1 for none) to use
    instead of HDBSCAN's, the rest of the stage unchanged: a grouping made elsewhere, or
    the masks grouped by their GT objects to measure what the clustering costs.
    """
    if colors is not None:
        colors = np.asarray(colors, dtype=np.float64)
        if colors.shape != (field.n, 3) or not np.isfinite(colors).all():
            raise ValueError(
                f"colors must be ({field.n}, 3) finite sRGB values, got shape {colors.shape}"
            )
    if mask_clusters is None:
        raw = cluster_masks(evidence.features, config)
    else:
        raw = np.asarray(mask_clusters)
        if raw.shape != (evidence.n,) or not np.issubdtype(raw.dtype, np.integer):
            raise ValueError(
                f"mask_clusters must be ({evidence.n},) integers, got {raw.shape} {raw.dtype}"
            )
        raw = raw.astype(np.int64)
    n_clusters = int(raw.max()) + 1 if raw.size else 0
    (cluster,) = by_first_appearance(raw)
    order = list(range(int(cluster.max(initial=-1)) + 1))
    feats = evidence.features.astype(np.float64)
    centers = _centers(feats, cluster, len(order), field.dim)
    votes: sp.csr_matrix | None = None
    structures = config.merge_structures if mask_labels is not None else ()
    if (config.merge_overlap < 1 or structures) and len(order) > 1:
        # clusters whose masks draw the same Gaussians, with features alike, are one
        # object seen from two sides (consensus.py), and the clusters of the floor or the
        # ceiling are one (structures.py); the views' votes serve the merge and, their
        # merged clusters' columns summed, the assignment
        votes, vote_rows = _view_votes(evidence, cluster, len(order))
        together = np.eye(len(order), dtype=bool)
        if config.merge_overlap < 1:
            alike = centers.astype(np.float64) @ centers.T.astype(np.float64)
            together |= (overlaps(votes) >= config.merge_overlap) & (alike >= config.merge_cosine)
        if structures:
            assert mask_labels is not None
            together |= structure_pairs(cluster_labels(cluster, mask_labels, len(order)),
                                        structures)  # fmt: skip
        merged = joined_clusters(cluster, together)
        n = int(merged.max()) + 1 if (merged >= 0).any() else 0
        if n < len(order):
            votes = _merge_columns(votes, cluster, merged, n)
            cluster, order = merged, list(range(n))
            centers = _centers(feats, cluster, n, field.dim)
    if config.assignment == "feature":
        rows = np.flatnonzero(field.supervised)
        scores = field.features[rows].astype(np.float64) @ centers.T
    else:
        if votes is None:
            votes, vote_rows = _view_votes(evidence, cluster, len(order))
        scores = _with_agreement(
            votes, vote_rows, centers, field.features, config.vote_feature_power
        )
        rows = vote_rows
    labels, score, kept = _assign(field.n, scores, rows, config)
    remap = np.full(len(order) + 1, -1, dtype=np.int64)
    remap[kept] = np.arange(kept.size)
    labels = remap[labels]
    voted = labels
    shares = None
    if config.assignment == "vote" and config.vote_smoothing > 0:
        shares = _shares(field.n, scores, rows, kept)
    labels = _propagate(voted, field, evidence, means, scales, quats, config, shares, colors)
    score = np.where((labels >= 0) & (labels == voted), score, 0.0)
    mask_entity = remap[cluster]
    centers = centers[kept]
    if config.split_gap > 0 and kept.size:
        labels, mask_entity = _split(labels, mask_entity, evidence, means, scales, config,
                                     mask_labels)  # fmt: skip
        mask_entity, labels = by_first_appearance(mask_entity, labels)
        n = int(mask_entity.max()) + 1 if (mask_entity >= 0).any() else 0
        centers = _centers(feats, mask_entity, n, field.dim)
    return InstanceAssignment(
        labels=labels,
        mask_entity=mask_entity,
        centers=centers.astype(np.float32),
        score=score.astype(np.float32),
        n_clusters=n_clusters,
        n_noise_masks=int((raw < 0).sum()),
    )


def _split(
    labels: np.ndarray,
    mask_entity: np.ndarray,
    evidence: MaskEvidence,
    means: np.ndarray,
    scales: np.ndarray,
    config: InstanceConfig,
    mask_labels: Sequence[str | None] | None,
) -> tuple[np.ndarray, np.ndarray]:
    """Entities in far-apart pieces split (step 5, :mod:`causalsplat.instances.pieces`);
    the floor and the ceiling are one entity however far apart their parts."""
    size = float(np.median(np.max(np.asarray(scales, dtype=np.float64), axis=1)))
    if not (np.isfinite(size) and size > 0):
        return labels, mask_entity
    keep: set[int] = set()
    if mask_labels is not None and config.merge_structures:
        k = int(mask_entity.max()) + 1 if (mask_entity >= 0).any() else 0
        named = cluster_labels(mask_entity, mask_labels, k)
        keep = {e for e, name in enumerate(named) if name in config.merge_structures}
    return split_pieces(labels, mask_entity, evidence.gaussian_weight, means,
                        gap=config.split_gap * size, min_share=PIECE_SHARE,
                        min_gaussians=config.min_gaussians, keep=keep)  # fmt: skip


def _centers(feats: np.ndarray, cluster: np.ndarray, k: int, dim: int) -> np.ndarray:
    """(k, dim) unit centres: the normalised mean feature of each cluster's masks."""
    return normalize_rows(
        np.array([feats[cluster == c].mean(axis=0) for c in range(k)]).reshape(-1, dim)
    )


def _view_votes(
    evidence: MaskEvidence, cluster: np.ndarray, k: int
) -> tuple[sp.csr_matrix, np.ndarray]:
    """(S, K) sparse per-view votes of each Gaussian for each cluster (step 3, before the
    feature agreement) and the Gaussians of the rows, indices (S,).

    Rows are the Gaussians drawn inside some clustered mask. Only the (Gaussian, cluster)
    pairs that received a vote are stored: a Gaussian is seen inside the masks of a few
    clusters, not of all K, so the memory grows with the votes cast, not with N x K.
    """
    coo = evidence.gaussian_weight.tocoo()
    keep = (cluster[coo.row] >= 0) & (coo.data > 0)
    mask, gauss, weight = coo.row[keep], coo.col[keep], coo.data[keep]
    del coo
    if weight.size == 0:
        return sp.csr_matrix((0, k)), np.zeros(0, dtype=np.int64)
    _, view = np.unique(evidence.view, return_inverse=True)
    n_views = int(view.max()) + 1
    # One unit vote per (Gaussian, view), split by weight among that view's clusters.
    _, pair = np.unique(gauss.astype(np.int64) * n_views + view[mask], return_inverse=True)
    share = weight / np.bincount(pair, weights=weight)[pair]
    rows, row_of = np.unique(gauss, return_inverse=True)
    votes = sp.csr_matrix((share, (row_of, cluster[mask])), shape=(rows.size, k))
    votes.sum_duplicates()  # also sorts each row's columns, which the ties rely on
    return votes, rows.astype(np.int64)


def _merge_columns(
    votes: sp.csr_matrix, before: np.ndarray, after: np.ndarray, n: int
) -> sp.csr_matrix:
    """The votes with the columns of merged clusters summed (a mask's cluster ``before``
    and ``after`` the merge; ``n`` clusters after)."""
    pairs = np.unique(np.stack([before, after])[:, before >= 0], axis=1)
    to = sp.csr_matrix((np.ones(pairs.shape[1]), (pairs[0], pairs[1])),
                       shape=(votes.shape[1], n))  # fmt: skip
    merged = sp.csr_matrix(votes @ to)
    merged.sum_duplicates()
    return merged


def _with_agreement(
    votes: sp.csr_matrix,
    rows: np.ndarray,
    centers: np.ndarray,
    features: np.ndarray,
    power: float,
) -> sp.csr_matrix:
    """The votes times the feature agreement ``max(0, f·C_k) ** power`` (step 3), scaled
    in place (the votes are not used again) and returned."""
    if power <= 0 or votes.nnz == 0:
        return votes
    out = votes
    row_idx = np.repeat(np.arange(rows.size), np.diff(out.indptr))
    f = features[rows].astype(np.float64)
    agree = np.einsum("ij,ij->i", f[row_idx], centers[out.indices].astype(np.float64))
    out.data *= np.clip(agree, 0.0, None) ** power
    return out


def _best_of(scores: np.ndarray | sp.csr_matrix, share: bool) -> tuple[np.ndarray, np.ndarray]:
    """Per row: the column of the highest score (first on ties) and that score, after
    dividing each row by its sum when ``share``. Scores are non-negative when sparse."""
    if sp.issparse(scores):
        sub = csr_row_shares(scores) if share else sp.csr_matrix(scores)
        sub.sort_indices()
        return csr_row_argmax(sub)
    dense = np.asarray(scores)
    if share:
        total = dense.sum(axis=1, keepdims=True)
        dense = np.divide(dense, total, out=np.zeros_like(dense), where=total > 0)
    best = dense.argmax(axis=1)
    return best, dense[np.arange(dense.shape[0]), best]


def _assign(
    n: int, scores: np.ndarray | sp.csr_matrix, rows: np.ndarray, config: InstanceConfig
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Labels (cluster index or -1), best score, and the kept cluster indices (step 3).

    ``scores`` (S, K) rank the clusters for the Gaussians ``rows``; vote scores are made
    shares of the Gaussian's total over the kept clusters.
    """
    labels = np.full(n, -1, dtype=np.int64)
    sim = np.zeros(n, dtype=np.float64)
    kept = np.arange(scores.shape[1])
    idx = rows
    if idx.size == 0 or kept.size == 0:
        return labels, sim, kept[:0]
    share = config.assignment == "vote"
    while True:
        best, best_sim = _best_of(scores[:, kept], share)
        ok = best_sim >= (config.min_vote_share if share else config.min_similarity)
        if share:  # no vote at all (every agreement 0) is no assignment, whatever the floor
            ok &= best_sim > 0
        counts = np.bincount(best[ok], minlength=kept.size)
        small = counts < config.min_gaussians
        if not small.any():
            break
        kept = kept[~small]
        if kept.size == 0:
            return labels, sim, kept
    labels[idx[ok]] = kept[best[ok]]
    sim[idx[ok]] = best_sim[ok]
    return labels, sim, kept


def _shares(
    n: int, scores: np.ndarray | sp.csr_matrix, rows: np.ndarray, kept: np.ndarray
) -> sp.csr_matrix:
    """(n, len(kept)) each Gaussian's vote shares over the kept clusters (rows summing
    to 1, or 0 for a Gaussian without a vote; ``scores`` (S, K) non-negative votes of the
    Gaussians ``rows``)."""
    sub = csr_row_shares(sp.csr_matrix(scores)[:, kept])
    place = sp.csr_matrix((np.ones(rows.size), (rows, np.arange(rows.size))),
                          shape=(n, rows.size))  # fmt: skip
    return sp.csr_matrix(place @ sub)


def _propagate(
    labels: np.ndarray,
    field: FeatureField,
    evidence: MaskEvidence,
    means: np.ndarray,
    scales: np.ndarray,
    quats: np.ndarray | None,
    config: InstanceConfig,
    shares: sp.csr_matrix | None = None,
    colors: np.ndarray | None = None,
) -> np.ndarray:
    """The well-seen Gaussians' votes smoothed along surfaces (with ``shares``, the
    (N, K) vote shares), then weakly seen and unassigned active Gaussians take labels
    along them (step 4)."""
    active = np.flatnonzero(field.active)
    if config.propagate_sigmas == 0 or active.size == 0 or not (labels >= 0).any():
        return labels
    sizes = np.asarray(scales, dtype=np.float64)[active]
    radius = config.propagate_sigmas * float(np.median(np.max(sizes, axis=1)))
    if not np.isfinite(radius) or radius <= 0:
        return labels
    seen = np.asarray(evidence.gaussian_weight.sum(axis=0)).ravel()[active]
    median = float(np.median(seen[seen > 0])) if (seen > 0).any() else 0.0
    floor = config.min_evidence * median
    fixed = (labels[active] >= 0) & (seen >= floor)
    graph = surface_graph(
        np.asarray(means)[active], sizes, None if quats is None else np.asarray(quats)[active],
        k=config.propagate_neighbors, radius=radius, coplanar=config.propagate_coplanar,
    )  # fmt: skip
    if config.propagate_feature_power > 0:
        graph = feature_weighted(graph, field.features[active], config.propagate_feature_power,
                                 field.supervised[active])  # fmt: skip
    if colors is not None and config.propagate_colour_sigma > 0:
        graph = colour_weighted(graph, np.asarray(colors)[active], config.propagate_colour_sigma)
    out = labels.copy()
    if shares is not None and fixed.any():
        well = np.flatnonzero(fixed)
        smoothed = smoothed_labels(graph[well][:, well], shares[active[well]],
                                   seen[well] / median if median > 0 else np.ones(well.size),
                                   config.vote_smoothing)  # fmt: skip
        out[active[well]] = np.where(smoothed >= 0, smoothed, out[active[well]])
    out[active] = harmonic_labels(graph, out[active], fixed)
    return out
