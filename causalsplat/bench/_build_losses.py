"""Where an exact-mask build loses panoptic quality, stage by stage (``causalsplat bench``).

On a scene built from exact masks (each mask is one GT object, every object told apart in
every view that sees it) the instance stage is run again with parts of it replaced by the
truth, on the same feature field and mask evidence:

* **visibility**: each Gaussian that some mask draws takes its GT object (what the views
  can tell at all);
* **masks voted directly**: each mask stands for the GT object holding most of its
  blending weight, and each Gaussian takes the object its masks' weights vote for (no
  field, no clustering, no propagation);
* **masks clustered by their GT objects**: the pipeline, with HDBSCAN's clusters replaced
  by the masks' GT objects (``assign_instances(mask_clusters=...)``): what the clustering
  costs;
* **weakly seen Gaussians given their GT objects**: the pipeline's labels, with those of
  the Gaussians seen less than ``instances.min_evidence`` times the median (the ones the
  surface propagation labels) replaced by the truth: what the propagation costs.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import scipy.sparse as sp

from causalsplat.build.pipeline import build_field, mask_labels
from causalsplat.field.types import MaskEvidence
from causalsplat.instances import assign_instances, scene_quality


def mask_objects(evidence: MaskEvidence, gt: np.ndarray) -> np.ndarray:
    """(M,) the GT object holding most of each mask's blending weight (-1: none, or the
    unlabelled Gaussians)."""
    return _heaviest(evidence.gaussian_weight, gt)


def _heaviest(weights: sp.spmatrix, labels: np.ndarray) -> np.ndarray:
    """(R,) for each row of ``weights`` (R, C), the label (of ``labels`` (C,), -1 for
    none) whose columns carry most of its weight; -1 where none carries any."""
    labelled = labels >= 0
    ids = np.unique(labels[labelled])
    col = np.searchsorted(ids, labels[labelled])
    onehot = sp.csr_matrix(
        (np.ones(col.size), (np.flatnonzero(labelled), col)), shape=(labels.size, ids.size)
    )
    weight = (weights @ onehot).toarray()
    best = weight.argmax(axis=1)
    return np.where(weight.max(axis=1) > 0, ids[best], -1).astype(np.int64)


def _weak_to_truth(built: np.ndarray, gt: np.ndarray, weak: np.ndarray) -> np.ndarray:
    """The build's labels with each weakly seen Gaussian of a GT object moved to the entity
    that holds most of the object's well-seen Gaussians (a new entity when none does)."""
    out = built.copy()
    fresh = int(built.max(initial=-1)) + 1
    for obj in np.unique(gt[weak & (gt >= 0)]):
        mine = gt == obj
        held = built[mine & ~weak]
        held = held[held >= 0]
        if held.size:
            target = int(np.bincount(held).argmax())
        else:
            target, fresh = fresh, fresh + 1
        out[mine & weak] = target
    return out


def stage_losses(
    folder: Path, build_label: str = "the build (exact masks)"
) -> tuple[list[str], dict[str, Any]]:
    """The table of the module docstring for one scene folder with GT labels, the first
    row (the pipeline as it is) named ``build_label``."""
    scene, config, field, evidence = build_field(folder)
    gt = scene.gt_labels
    if gt is None:
        raise ValueError(f"{folder} has no GT labels (gt/gt_labels.npy)")
    g = scene.gaussians
    kwargs = dict(means=g.means, scales=g.scales, quats=g.quats,
                  mask_labels=mask_labels(scene, evidence), colors=g.colors)  # fmt: skip
    built = assign_instances(field, evidence, config.instances, **kwargs).labels
    objects = mask_objects(evidence, gt)
    seen = np.asarray(evidence.gaussian_weight.sum(axis=0)).ravel()
    weak = seen < config.instances.min_evidence * float(np.median(seen[seen > 0]))
    voted = _heaviest(evidence.gaussian_weight.T.tocsr(), objects)
    oracle = assign_instances(field, evidence, config.instances, mask_clusters=objects,
                              **kwargs).labels  # fmt: skip
    rows = [
        (build_label, built),
        ("visibility: GT object of each Gaussian some mask draws", np.where(seen > 0, gt, -1)),
        ("masks voted directly (each mask's GT object, no field)", voted),
        ("masks clustered by their GT objects, rest of the build", oracle),
        (
            "the build, weakly seen Gaussians given their GT objects",
            _weak_to_truth(built, gt, weak),
        ),
    ]
    lines = [
        "| labels | PQ | SQ | RQ | split | merged | missed | extra |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    data: dict[str, Any] = {}
    for name, labels in rows:
        q = scene_quality(labels, gt)
        data[name] = q.to_json()
        lines.append(f"| {name} | {q.pq:.3f} | {q.sq:.3f} | {q.rq:.3f} | {q.split} | "
                     f"{q.merged} | {q.missed} | {q.extra} |")  # fmt: skip
    counted = gt >= 0
    right = (voted == gt) & counted
    share = float(weak[counted].mean())
    data["weak_share"] = share
    data["vote_right_well"] = float(right[~weak & counted].mean())
    data["vote_right_weak"] = float(right[weak & counted].mean())
    lines += [
        "",
        f"{share:.1%} of the GT-labelled Gaussians are weakly seen (evidence below "
        f"{config.instances.min_evidence:g}x the median); the masks' direct vote names their "
        f"GT object for {data['vote_right_well']:.1%} of the others and "
        f"{data['vote_right_weak']:.1%} of them.",
    ]
    return lines, data
