"""Quality of a per-Gaussian instance labelling against a ground-truth one.

The numbers 3D instance-segmentation papers report, for one class-agnostic set of
instances: the mean best IoU of the ground-truth instances and the average precision at
IoU 0.5 and 0.25.

Every element (a Gaussian, or a point) carries one predicted and one ground-truth label;
a negative label means unlabelled. An instance is the set of elements sharing a label, and
the IoU of a ground-truth instance ``g`` and a predicted instance ``p`` is
``|g ∩ p| / |g ∪ p|`` on those sets: counts, or sums of per-element weights (e.g. Gaussian
opacity) when weights are given.

Ground-truth instances smaller than ``min_size`` (count, or weight) and those whose id is in
``ignore`` are left out. A predicted instance with more than half of its elements (weight)
on left-out ground-truth instances is ignored too, ScanNet style; it counts neither as a
true nor as a false positive, nor towards the best IoU of any ground-truth instance.

Average precision at threshold ``t`` ranks the predicted instances by score (descending;
ties: smaller predicted id first) and matches each, greedily, to the still unmatched
ground-truth instance of highest IoU with ``IoU >= t`` (ties: smaller ground-truth id).
A match is a true positive, anything else a false positive. AP is the area under the
precision-recall curve with all-points interpolation: precision made non-increasing from
the right, summed over the recall steps (each true positive raises recall by ``1 / n_gt``).

Panoptic quality (Kirillov et al., 2019), class-agnostic: a ground-truth and a predicted
instance *match* when their IoU exceeds 0.5 (such a match is unique on both sides);
``SQ`` is the mean IoU of the matches, ``RQ = TP / (TP + FP / 2 + FN / 2)`` and
``PQ = SQ * RQ``, where TP counts matches, FP unmatched predicted instances (*extra*) and
FN unmatched ground-truth ones (*missed*). Elements without a ground-truth label are
*void*, as in that paper: with ``void="ignored"`` (the default) they are taken out of each
predicted instance before its IoU for the match is computed, and a predicted instance more
than half void is no false positive (a reconstruction holds surfaces nobody annotated:
ScanNet leaves 5 % of scene0000_00's Gaussians unlabelled, and an entity that takes the
unannotated floor behind a nightstand is no worse a nightstand for it). ``void="counted"``
keeps them in the union, as the mean best IoU and AP do (ScanNet's instance benchmark
counts them there too). How objects fall apart is counted beside it: a
ground-truth instance is *split* when two or more predicted instances each hold at least
:data:`PART` of it, and a predicted instance *merged* when it holds at least
:data:`PART` of each of two or more ground-truth instances.

All pairwise intersections come from one sparse contingency matrix, so a million elements
and a thousand instances take a fraction of a second.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, replace
from numbers import Real
from typing import Any, Literal, get_args

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike

__all__ = [
    "PANOPTIC_MIN_SIZE",
    "PART",
    "InstanceQuality",
    "Void",
    "instance_quality",
    "scene_quality",
]

#: How the panoptic figures treat elements without a ground-truth label (module docstring).
Void = Literal["ignored", "counted"]
VOIDS: tuple[Void, ...] = get_args(Void)

#: The share of a ground-truth instance a predicted one must hold to count as a part of it
#: (for ``split`` and ``merged``).
PART = 0.2
#: Ground-truth instances of fewer Gaussians than this are left out of a built scene's
#: panoptic figures (:func:`scene_quality`): a few stray Gaussians are no object anyone
#: asks about.
PANOPTIC_MIN_SIZE = 50


@dataclass(frozen=True, slots=True)
class InstanceQuality:
    """Quality of a predicted instance labelling against the ground truth."""

    n_gt: int
    """Ground-truth instances evaluated (after ``min_size`` and ``ignore``)."""
    n_pred: int
    """Predicted instances evaluated (label >= 0, not ignored for lying on left-out GT)."""
    mean_best_iou: float
    """Mean over GT instances of the best IoU with any predicted instance; nan if no GT."""
    ap50: float
    """Average precision at IoU >= 0.5; nan if no GT."""
    ap25: float
    """Average precision at IoU >= 0.25; nan if no GT."""
    best_iou: dict[int, float]
    """Per evaluated GT id, its best IoU (0.0 when no prediction overlaps it)."""
    matched: dict[int, int]
    """GT id -> the predicted id giving its best IoU (only where that IoU > 0)."""
    pq: float = math.nan
    """Panoptic quality ``SQ * RQ`` (module docstring); nan if no GT and no prediction."""
    sq: float = math.nan
    """Mean IoU of the matches (IoU > 0.5); nan without a match."""
    rq: float = math.nan
    """``TP / (TP + FP / 2 + FN / 2)``; nan if no GT and no prediction."""
    split: int = 0
    """GT instances two or more predicted instances each hold at least :data:`PART` of."""
    merged: int = 0
    """Predicted instances holding at least :data:`PART` of each of two or more GT ones."""
    missed: int = 0
    """GT instances without a match (FN)."""
    extra: int = 0
    """Predicted instances without a match (FP)."""
    panoptic_min_size: float = 1
    """The ``min_size`` of the ground-truth instances the panoptic figures count."""
    void: Void = "ignored"
    """How the panoptic figures treated unlabelled elements (module docstring)."""

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready dict: string keys for the per-instance maps, nan as ``None``."""

        def num(x: float) -> float | None:
            return None if math.isnan(x) else x

        return {
            "n_gt": self.n_gt,
            "n_pred": self.n_pred,
            "mean_best_iou": num(self.mean_best_iou),
            "ap50": num(self.ap50),
            "ap25": num(self.ap25),
            "pq": num(self.pq),
            "sq": num(self.sq),
            "rq": num(self.rq),
            "split": self.split,
            "merged": self.merged,
            "missed": self.missed,
            "extra": self.extra,
            "panoptic_min_size": self.panoptic_min_size,
            "void": self.void,
            "best_iou": {str(g): num(v) for g, v in self.best_iou.items()},
            "matched": {str(g): p for g, p in self.matched.items()},
        }


def _labels(a: ArrayLike, name: str) -> np.ndarray:
    arr = np.asarray(a)
    if arr.size == 0 and arr.dtype.kind in "fiu":
        return arr.astype(np.int64).ravel()
    if arr.dtype.kind not in "iu":
        raise ValueError(f"{name} must hold integer labels, got dtype {arr.dtype}")
    return arr.astype(np.int64, copy=False).ravel()


def _weights(weights: ArrayLike, shape: tuple[int, ...]) -> np.ndarray:
    w = np.asarray(weights)
    if w.dtype.kind not in "fiub":
        raise ValueError(f"weights must be numeric, got dtype {w.dtype}")
    if w.shape != shape:
        raise ValueError(f"weights shape {w.shape} does not match the labels' shape {shape}")
    w = w.astype(np.float64).ravel()
    if not np.all(np.isfinite(w)):
        raise ValueError("weights must be finite")
    if np.any(w < 0):
        raise ValueError("weights must be non-negative")
    return w


def _instances(
    labels: np.ndarray, w: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(labelled mask, sorted ids, per-labelled-element instance index, instance sizes)."""
    lab = labels >= 0
    ids, inv = np.unique(labels[lab], return_inverse=True)
    inv = inv.ravel()
    if w is None:
        size: np.ndarray = np.bincount(inv, minlength=len(ids)).astype(np.int64)
    else:
        size = np.bincount(inv, weights=w[lab], minlength=len(ids))
    return lab, ids, inv, size


def _average_precision(tp: np.ndarray, n_gt: int) -> float:
    """All-points interpolated AP of a ranked list of true/false positives."""
    if n_gt == 0:
        return math.nan
    if tp.size == 0 or not tp.any():
        return 0.0
    cum_tp = np.cumsum(tp)
    precision = cum_tp / np.arange(1, tp.size + 1)
    # precision made non-increasing from the right
    interp = np.maximum.accumulate(precision[::-1])[::-1]
    # recall rises by exactly 1 / n_gt at every true positive
    return math.fsum(interp[tp].tolist()) / n_gt


def instance_quality(
    pred: ArrayLike,
    gt: ArrayLike,
    *,
    scores: Mapping[int, float] | None = None,
    min_size: int = 1,
    ignore: Iterable[int] = (),
    weights: ArrayLike | None = None,
    void: Void = "ignored",
) -> InstanceQuality:
    """Mean best IoU, AP50 and AP25 of predicted instances against ground-truth ones.

    ``pred`` and ``gt`` hold one integer label per element (same shape; negative =
    unlabelled). ``scores`` maps every evaluated predicted id to its confidence (default:
    the predicted instance's size, i.e. count or weight). ``min_size`` and ``ignore`` leave
    ground-truth instances out (see the module docstring), ``weights`` (one non-negative
    finite value per element) turns every count into a weighted sum. ``void``: how the
    panoptic figures treat elements without a ground-truth label (module docstring).

    Raises ``ValueError`` on mismatched shapes, non-integer labels, bad weights, a negative
    ``min_size``, an unknown ``void``, or a missing or non-finite score.
    """
    if void not in VOIDS:
        raise ValueError(f"void must be one of {', '.join(VOIDS)}, got {void!r}")
    pred_arr, gt_arr = np.asarray(pred), np.asarray(gt)
    if pred_arr.shape != gt_arr.shape:
        raise ValueError(
            f"pred and gt must have the same shape, got pred {pred_arr.shape} and gt {gt_arr.shape}"
        )
    shape = pred_arr.shape
    p_lab_all = _labels(pred_arr, "pred")
    g_lab_all = _labels(gt_arr, "gt")
    w = None if weights is None else _weights(weights, shape)
    if isinstance(min_size, bool) or not isinstance(min_size, Real) or min_size < 0:
        raise ValueError(f"min_size must be a non-negative number, got {min_size!r}")
    ignore_ids = np.asarray([int(i) for i in ignore], dtype=np.int64)

    g_lab, g_ids, g_inv, g_size = _instances(g_lab_all, w)
    p_lab, p_ids, p_inv, p_size = _instances(p_lab_all, w)
    n_g, n_p = len(g_ids), len(p_ids)

    keep_g = (g_size >= min_size) & ~np.isin(g_ids, ignore_ids)

    # per-element instance index (-1 = unlabelled)
    g_idx = np.full(g_lab_all.shape, -1, dtype=np.int64)
    g_idx[g_lab] = g_inv
    p_idx = np.full(p_lab_all.shape, -1, dtype=np.int64)
    p_idx[p_lab] = p_inv

    # predicted instances mostly (> 50%) on left-out GT instances are ignored
    left_out = np.zeros(g_lab_all.shape, dtype=bool)
    left_out[g_lab] = ~keep_g[g_inv]
    on_left_out = p_lab & left_out
    lo_w = None if w is None else w[on_left_out]
    p_left_out = np.bincount(p_idx[on_left_out], weights=lo_w, minlength=n_p)
    keep_p = ~(p_left_out > 0.5 * p_size)

    # all pairwise intersections: sparse contingency matrix over (gt index, pred index)
    both = g_lab & p_lab
    data = np.ones(int(both.sum()), dtype=np.int64) if w is None else w[both]
    cont = sp.coo_matrix((data, (g_idx[both], p_idx[both])), shape=(n_g, n_p)).tocsr()
    cont.sum_duplicates()
    cont.eliminate_zeros()
    coo = cont.tocoo()
    rows = coo.row.astype(np.int64)
    cols = coo.col.astype(np.int64)
    inter = coo.data
    sel = keep_g[rows] & keep_p[cols]
    rows, cols, inter = rows[sel], cols[sel], inter[sel]
    union = g_size[rows] + p_size[cols] - inter
    iou = np.where(union > 0, inter / np.where(union > 0, union, 1), 0.0).astype(np.float64)

    kept_g = np.flatnonzero(keep_g)
    kept_p = np.flatnonzero(keep_p)
    n_gt, n_pred = len(kept_g), len(kept_p)

    # best IoU per GT instance: highest IoU, ties to the smaller predicted id
    best = np.zeros(n_g, dtype=np.float64)
    best_p = np.full(n_g, -1, dtype=np.int64)
    if rows.size:
        order = np.lexsort((cols, -iou, rows))
        first = np.ones(order.size, dtype=bool)
        first[1:] = rows[order][1:] != rows[order][:-1]
        top = order[first]
        best[rows[top]] = iou[top]
        best_p[rows[top]] = cols[top]
    best_iou = {int(g_ids[g]): float(best[g]) for g in kept_g}
    matched = {int(g_ids[g]): int(p_ids[best_p[g]]) for g in kept_g if best[g] > 0}
    mean_best = math.fsum(best[kept_g].tolist()) / n_gt if n_gt else math.nan

    # ranking: score descending, ties to the smaller predicted id
    if scores is None:
        score = p_size[kept_p].astype(np.float64)
    else:
        vals = []
        for p in kept_p:
            pid = int(p_ids[p])
            if pid not in scores:
                raise ValueError(f"scores has no entry for predicted instance {pid}")
            s = float(scores[pid])
            if not math.isfinite(s):
                raise ValueError(f"score of predicted instance {pid} is not finite: {s}")
            vals.append(s)
        score = np.asarray(vals, dtype=np.float64)
    ranked = kept_p[np.lexsort((p_ids[kept_p], -score))]

    # candidates per predicted instance, best IoU first (ties: smaller GT id)
    order = np.lexsort((rows, -iou, cols))
    c_rows, c_iou = rows[order], iou[order]
    starts = np.searchsorted(cols[order], np.arange(n_p + 1))

    def ap_at(threshold: float) -> float:
        if n_gt == 0:
            return math.nan
        taken = np.zeros(n_g, dtype=bool)
        tp = np.zeros(n_pred, dtype=bool)
        for k, p in enumerate(ranked):
            for j in range(starts[p], starts[p + 1]):
                if c_iou[j] < threshold:
                    break
                g = c_rows[j]
                if not taken[g]:
                    taken[g] = True
                    tp[k] = True
                    break
        return _average_precision(tp, n_gt)

    # panoptic quality: matches at IoU > 0.5 are one-to-one; void (unlabelled GT) elements
    # leave the predicted instances first, and one more than half void is no false positive
    pq_iou, pq_pred = iou, n_pred
    if void == "ignored":
        on_void = p_lab & ~g_lab
        p_void = np.bincount(p_idx[on_void], weights=None if w is None else w[on_void],
                             minlength=n_p)  # fmt: skip
        pq_union = g_size[rows] + (p_size[cols] - p_void[cols]) - inter
        pq_iou = np.where(pq_union > 0, inter / np.where(pq_union > 0, pq_union, 1), 0.0)
        pq_pred = int(np.count_nonzero(keep_p & ~(p_void > 0.5 * p_size)))
    hit = pq_iou > 0.5
    tp = int(hit.sum())
    fn, fp = n_gt - tp, pq_pred - tp
    denom = tp + 0.5 * fp + 0.5 * fn
    sq = math.fsum(pq_iou[hit].tolist()) / tp if tp else math.nan
    rq = tp / denom if denom else math.nan
    pq = (0.0 if not tp else sq * rq) if denom else math.nan
    part = inter >= PART * g_size[rows]
    split = int(np.count_nonzero(np.bincount(rows[part], minlength=n_g) >= 2))
    pairs = np.unique(np.stack([cols[part], rows[part]]), axis=1) if part.any() else None
    merged = 0 if pairs is None else int(np.count_nonzero(np.bincount(pairs[0]) >= 2))

    return InstanceQuality(
        n_gt=n_gt,
        n_pred=n_pred,
        mean_best_iou=float(mean_best),
        ap50=float(ap_at(0.5)),
        ap25=float(ap_at(0.25)),
        best_iou=best_iou,
        matched=matched,
        pq=float(pq),
        sq=float(sq),
        rq=float(rq),
        split=split,
        merged=merged,
        missed=fn,
        extra=fp,
        panoptic_min_size=min_size,
        void=void,
    )


def scene_quality(
    pred: ArrayLike,
    gt: ArrayLike,
    *,
    panoptic_min_size: int = PANOPTIC_MIN_SIZE,
    void: Void = "ignored",
) -> InstanceQuality:
    """A built scene's quality against its GT instances, as ``build`` reports it: mean best
    IoU and AP over every GT instance, the panoptic figures (PQ, SQ, RQ, split, merged,
    missed, extra) over those of at least ``panoptic_min_size`` elements, with ``void``
    (unlabelled) elements ignored or counted (module docstring).

    >>> import numpy as np
    >>> gt = np.repeat([0, 1, 2], [100, 100, 3])
    >>> q = scene_quality(np.repeat([0, 1, 2], [100, 100, 3]), gt)
    >>> q.n_gt, q.pq, q.missed
    (3, 1.0, 0)
    """
    q = instance_quality(pred, gt)
    p = instance_quality(pred, gt, min_size=panoptic_min_size, void=void)
    return replace(q, pq=p.pq, sq=p.sq, rq=p.rq, split=p.split, merged=p.merged,
                   missed=p.missed, extra=p.extra, panoptic_min_size=panoptic_min_size,
                   void=void)  # fmt: skip
