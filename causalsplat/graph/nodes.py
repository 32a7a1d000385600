"""Scene-graph nodes from a 3D instance assignment: geometry, category, colour, provenance.

For entity ``k`` with Gaussians ``G_k`` (label ``k`` in the assignment):

* ``bbox_min`` / ``bbox_max``: per-axis quantiles ``bbox_quantile`` and ``1 - bbox_quantile``
  of the centres (the Gaussians a neighbour's masks leaked into the entity do not blow the
  box up); ``centroid``: per axis, the mean of the centres inside that range (the trimmed
  mean, so the centroid always lies in the box); ``point_count``: ``|G_k|``;
* ``category``: the label with the largest vote among the entity's masks, each mask
  voting with its summed pixel weight times its score (1 when the masks have none) times
  its agreement, the share of its Gaussian weight on the entity's Gaussians (a fragment
  of a door mask clustered with pieces of wall and floor names a piece of wall, not a
  door: most of what it draws went to the door);
  ``confidence``: that label's share of the vote; masks without labels give the category
  ``"object"`` (a labeller, e.g. the VLM one, names it later);
* attributes: the vote shares of every label (``label_vote``, source ``mask-vote``) and
  the colour name of the median Gaussian colour (``color``, source ``geometry``);
* views and masks: every view the build used and every mask it read, with the entity
  each mask was assigned to (``None``: noise, too small, or dropped).
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from causalsplat._checks import Interval, check_fields
from causalsplat.colors import mean_color, names_of, rgb_to_hex
from causalsplat.field.types import MaskEvidence
from causalsplat.graph.errors import GraphBuildError
from causalsplat.instances.assign import InstanceAssignment
from causalsplat.io.types import Camera, GaussianScene
from causalsplat.masks import MaskSet
from graph_store import Attribute, AttributeSource, Entity, MaskRecord, View

UNLABELLED = "object"


@dataclass(frozen=True, slots=True)
class NodeConfig:
    """Options of :func:`build_entities`.

    Attributes:
        bbox_quantile: per-axis quantile trimmed from each side of an entity's box. 0.1:
            on the built synthetic scenes the support and proximity edges of trimmed
            boxes answer far more generated questions (small, seed 0: 70% of them with
            0.01, 97.5% with 0.1; scene0000_00 unchanged), as the few percent of
            Gaussians labelled with a neighbour otherwise stretch a box down to the
            floor or across to the next object.
        min_votes_share: label votes below this share are not stored as ``label_vote``.
    """

    bbox_quantile: float = 0.1
    min_votes_share: float = 0.05

    def __post_init__(self) -> None:
        check_fields(
            "NodeConfig",
            {"bbox_quantile": self.bbox_quantile, "min_votes_share": self.min_votes_share},
            {"bbox_quantile": Interval(0, 0.5, high_open=True), "min_votes_share": Interval(0, 1)},
            GraphBuildError,
        )


def build_entities(
    scene: GaussianScene,
    assignment: InstanceAssignment,
    evidence: MaskEvidence,
    masksets: Sequence[MaskSet],
    config: NodeConfig | None = None,
) -> tuple[Entity, ...]:
    """One :class:`Entity` per entity id that owns at least one Gaussian (module doc)."""
    config = config or NodeConfig()
    votes = _label_votes(assignment, evidence, masksets)
    colors = scene.colors
    opacities = scene.opacities
    means = scene.means.astype(np.float64)
    entities = []
    for k in range(assignment.n_entities):
        idx = np.flatnonzero(assignment.labels == k)
        if idx.size == 0:
            continue
        pts = means[idx]
        q = config.bbox_quantile
        lo = np.quantile(pts, q, axis=0) if q > 0 else pts.min(axis=0)
        hi = np.quantile(pts, 1 - q, axis=0) if q > 0 else pts.max(axis=0)
        centroid = _trimmed_mean(pts, lo, hi)
        tally = votes.get(k, {})
        total = sum(tally.values())
        if total > 0:
            category = max(sorted(tally), key=lambda name: tally[name])
            confidence: float | None = tally[category] / total
        else:
            category, confidence = UNLABELLED, None
        attrs = [
            Attribute("label_vote", f"{name}:{tally[name] / total:.3f}", AttributeSource.MASK_VOTE)
            for name in sorted(tally, key=lambda n: (-tally[n], n))
            if total > 0 and tally[name] / total >= config.min_votes_share
        ]
        rgb = mean_color(colors[idx], opacities[idx])
        if rgb is not None:
            attrs.append(Attribute("rgb", rgb_to_hex(rgb), AttributeSource.GEOMETRY))
            attrs.append(Attribute("color", names_of(rgb)[0], AttributeSource.GEOMETRY))
        entities.append(
            Entity(
                id=k,
                category=category,
                centroid=tuple(float(v) for v in centroid),  # type: ignore[arg-type]
                bbox_min=tuple(float(v) for v in lo),  # type: ignore[arg-type]
                bbox_max=tuple(float(v) for v in hi),  # type: ignore[arg-type]
                point_count=int(idx.size),
                confidence=confidence,
                attributes=tuple(attrs),
            )
        )
    return tuple(entities)


def _label_votes(
    assignment: InstanceAssignment, evidence: MaskEvidence, masksets: Sequence[MaskSet]
) -> dict[int, dict[str, float]]:
    """Per entity, label -> vote (module docstring); an entity none of whose masks
    agrees with it (each drew only Gaussians that went elsewhere) is voted for by pixel
    weight and score alone."""
    votes: dict[int, dict[str, float]] = defaultdict(lambda: defaultdict(float))
    plain: dict[int, dict[str, float]] = defaultdict(lambda: defaultdict(float))
    agree = mask_agreement(assignment, evidence)
    for row, k in enumerate(assignment.mask_entity.tolist()):
        ms = masksets[int(evidence.view[row])]
        if k < 0 or ms.labels is None:
            continue
        i = int(evidence.index[row])
        vote = float(evidence.pixel_weight[row]) * (
            1.0 if ms.scores is None else float(ms.scores[i])
        )
        plain[k][ms.labels[i]] += vote
        votes[k][ms.labels[i]] += vote * float(agree[row])
    return {k: dict(votes[k] if sum(votes[k].values()) > 0 else v) for k, v in plain.items()}


def mask_agreement(assignment: InstanceAssignment, evidence: MaskEvidence) -> np.ndarray:
    """(M,) each mask's share of its Gaussian weight (``evidence.gaussian_weight`` row) on
    Gaussians labelled with the mask's entity; 0 for a mask without an entity or weight.

    >>> import scipy.sparse as sp
    >>> from causalsplat.instances.assign import InstanceAssignment
    >>> a = InstanceAssignment(labels=np.array([0, 0, 1]), mask_entity=np.array([0, 1, -1]),
    ...                        centers=np.zeros((2, 1), np.float32),
    ...                        score=np.ones(3, np.float32), n_clusters=2, n_noise_masks=1)
    >>> w = sp.csr_matrix(np.array([[1.0, 1.0, 2.0], [3.0, 0.0, 1.0], [1.0, 0.0, 0.0]]))
    >>> ev = MaskEvidence(view=np.zeros(3, np.int64), index=np.arange(3), pixel_weight=np.ones(3),
    ...                   features=np.zeros((3, 1), np.float32), gaussian_weight=w)
    >>> mask_agreement(a, ev).tolist()
    [0.5, 0.25, 0.0]
    """
    weight = evidence.gaussian_weight.tocoo()
    entity = assignment.mask_entity[weight.row]
    on = (entity >= 0) & (assignment.labels[weight.col] == entity)
    m = evidence.n
    total = np.bincount(weight.row, weights=weight.data, minlength=m)
    inside = np.bincount(weight.row, weights=np.where(on, weight.data, 0.0), minlength=m)
    return np.divide(inside, total, out=np.zeros(m), where=total > 0)


def build_provenance(
    cameras: Sequence[Camera],
    masksets: Sequence[MaskSet],
    evidence: MaskEvidence,
    assignment: InstanceAssignment,
    entity_ids: set[int],
) -> tuple[tuple[View, ...], tuple[MaskRecord, ...]]:
    """The views of the build and one record per mask read (module docstring)."""
    out_views = tuple(
        View(id=i, name=ms.view, width=cam.width, height=cam.height)
        for i, (cam, ms) in enumerate(zip(cameras, masksets, strict=True))
    )
    entity_of = {
        (int(v), int(j)): int(k)
        for v, j, k in zip(evidence.view, evidence.index, assignment.mask_entity, strict=True)
    }
    records = []
    for i, ms in enumerate(masksets):
        for j in range(ms.n):
            k = entity_of.get((i, j), -1)
            records.append(
                MaskRecord(
                    view=i,
                    index=j,
                    entity=k if k in entity_ids else None,
                    label=None if ms.labels is None else ms.labels[j],
                    score=None if ms.scores is None else float(ms.scores[j]),
                )
            )
    return out_views, tuple(records)


def _trimmed_mean(pts: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Per axis, the mean of the coordinates in ``[lo, hi]``, clipped into it against rounding.

    An axis with no coordinate inside (two points and an interpolated quantile) takes the
    plain mean, clipped.
    """
    inside = (pts >= lo) & (pts <= hi)
    count = inside.sum(axis=0)
    trimmed = np.where(inside, pts, 0.0).sum(axis=0) / np.maximum(count, 1)
    return np.clip(np.where(count > 0, trimmed, pts.mean(axis=0)), lo, hi)
