"""Instance quality (mean best IoU, AP50, AP25) against hand-computed values and a reference."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from causalsplat.instances.quality import InstanceQuality, Void, instance_quality, scene_quality


def close(a: float, b: float) -> bool:
    return math.isclose(a, b, rel_tol=1e-12, abs_tol=1e-12)


# -- exact cases -------------------------------------------------------------------------


def test_identical_labels() -> None:
    gt = np.array([0, 0, 1, 1, 1, -1, 2, 2, 5])
    q = instance_quality(gt, gt)
    assert q.n_gt == 4 and q.n_pred == 4
    assert q.mean_best_iou == 1.0 and q.ap50 == 1.0 and q.ap25 == 1.0
    assert q.best_iou == {0: 1.0, 1: 1.0, 2: 1.0, 5: 1.0}
    assert q.matched == {0: 0, 1: 1, 2: 2, 5: 5}
    assert all(type(v) is float for v in q.best_iou.values())
    assert type(q.ap50) is float and type(q.mean_best_iou) is float


def test_identical_up_to_permutation() -> None:
    gt = np.array([0, 0, 1, 1, 1, -1, 2, 2, 5, 5, 5, 5])
    bijection = {0: 7, 1: 3, 2: 40, 5: 0}
    pred = np.array([bijection.get(int(g), -1) for g in gt])
    q = instance_quality(pred, gt, scores={7: 0.1, 3: 0.9, 40: 0.5, 0: 0.2})
    assert q.mean_best_iou == 1.0 and q.ap50 == 1.0 and q.ap25 == 1.0
    assert q.matched == bijection


def test_hand_computed_two_gt_three_predictions() -> None:
    # element:  0  1  2  3  4  5  6  7  8  9
    gt = np.array([1, 1, 1, 1, 1, 1, 2, 2, 2, 2])  # A = 1 (6 elements), B = 2 (4 elements)
    pred = np.array([10, 10, 10, 10, 20, 20, 20, 30, 30, 30])
    # IoUs:
    #   |{0..3}| / |{0..5}|            = 4 / 6           = 2/3
    #   |{4,5}|  / |{0..6}|            = 2 / (6+3-2)     = 2/7  (~0.286)
    #   B-20: |{6}|    / |{4..9}|            = 1 / (4+3-1)     = 1/6
    #   B-30: |{7,8,9}| / |{6..9}|           = 3 / 4           = 3/4
    # best IoU: A 2/3 (pred 10), B 3/4 (pred 30); mean = (2/3 + 3/4) / 2 = 17/24
    #
    # scores 20: 0.9 > 10: 0.8 > 30: 0.7
    # AP50: 20 -> best candidate A at 2/7 < 0.5: FP; 10 -> A (2/3): TP; 30 -> B (3/4): TP
    #   tp = F T T, precision 0, 1/2, 2/3 -> interpolated 2/3, 2/3, 2/3
    #   AP = (2/3 + 2/3) / 2 = 2/3
    # AP25: 20 -> A at 2/7 >= 0.25: TP (takes A); 10 -> A taken, no B overlap: FP; 30 -> B: TP
    #   tp = T F T, precision 1, 1/2, 2/3 -> interpolated 1, 2/3, 2/3
    #   AP = (1 + 2/3) / 2 = 5/6
    q = instance_quality(pred, gt, scores={10: 0.8, 20: 0.9, 30: 0.7})
    assert q.n_gt == 2 and q.n_pred == 3
    assert close(q.best_iou[1], 2 / 3) and close(q.best_iou[2], 3 / 4)
    assert q.matched == {1: 10, 2: 30}
    assert close(q.mean_best_iou, 17 / 24)
    assert close(q.ap50, 2 / 3)
    assert close(q.ap25, 5 / 6)

    # default scores = sizes: 10 (4) > 20 (3) = 30 (3), the tie to the smaller id (20)
    # AP50: 10 TP, 20 FP, 30 TP -> precision 1, 1/2, 2/3 -> interp 1, 2/3, 2/3 -> 5/6
    # AP25: 10 takes A: TP; 20: A taken, B at 1/6 < 0.25: FP; 30: TP -> 5/6 as well
    q = instance_quality(pred, gt)
    assert close(q.ap50, 5 / 6) and close(q.ap25, 5 / 6)
    assert close(q.mean_best_iou, 17 / 24)


def test_over_segmentation_into_thirds() -> None:
    # one GT instance of 6 split in three pairs: every IoU = 2/6 = 1/3
    gt = np.zeros(6, dtype=np.int32)
    pred = np.array([0, 0, 1, 1, 2, 2])
    q = instance_quality(pred, gt)
    assert close(q.best_iou[0], 1 / 3) and q.matched == {0: 0}
    assert q.ap50 == 0.0
    # AP25: the first prediction takes the GT (TP), the other two are FP:
    # precision 1, 1/2, 1/3 -> interpolated 1, 1/2, 1/3; one recall step of 1 -> AP 1
    assert q.ap25 == 1.0


def test_over_segmentation_into_halves() -> None:
    # two exact halves: IoU 2/4 = 0.5 each; the threshold is inclusive (IoU >= t), so the
    # first half is a TP at 0.5 and the second an FP -> AP50 = AP25 = 1
    gt = np.zeros(4, dtype=np.int64)
    pred = np.array([3, 3, 4, 4])
    q = instance_quality(pred, gt)
    assert q.best_iou == {0: 0.5} and q.mean_best_iou == 0.5
    assert q.matched == {0: 3}  # tie to the smaller predicted id
    assert q.ap50 == 1.0 and q.ap25 == 1.0


def test_under_segmentation() -> None:
    # GT 0 (2 elements) and GT 1 (6 elements) merged into one prediction of 8:
    # IoU 2/8 = 0.25 and 6/8 = 0.75, mean 0.5
    gt = np.array([0, 0, 1, 1, 1, 1, 1, 1])
    pred = np.full(8, 9)
    q = instance_quality(pred, gt)
    assert q.best_iou == {0: 0.25, 1: 0.75} and q.mean_best_iou == 0.5
    assert q.matched == {0: 9, 1: 9}
    # the one prediction matches GT 1 (highest IoU) at both thresholds: precision 1,
    # recall 1/2 -> AP 1/2
    assert q.ap50 == 0.5 and q.ap25 == 0.5


def test_empty_prediction() -> None:
    gt = np.array([0, 0, 1, 1])
    q = instance_quality(np.full(4, -1), gt)
    assert q.n_gt == 2 and q.n_pred == 0
    assert q.mean_best_iou == 0.0 and q.ap50 == 0.0 and q.ap25 == 0.0
    assert q.best_iou == {0: 0.0, 1: 0.0} and q.matched == {}


def test_no_ground_truth() -> None:
    q = instance_quality(np.array([0, 0, 1]), np.array([-1, -1, -1]))
    assert q.n_gt == 0 and q.n_pred == 2
    assert math.isnan(q.mean_best_iou) and math.isnan(q.ap50) and math.isnan(q.ap25)
    j = q.to_json()
    assert j["mean_best_iou"] is None and j["ap50"] is None and j["ap25"] is None
    json.dumps(j, allow_nan=False)


def test_empty_arrays() -> None:
    q = instance_quality([], [])
    assert q.n_gt == 0 and q.n_pred == 0 and math.isnan(q.ap50)


def test_min_size_filter() -> None:
    # GT 0: 5 elements, GT 1: 1 element (left out with min_size=2)
    gt = np.array([0, 0, 0, 0, 0, 1, -1, -1])
    # pred 7 exactly covers the small GT -> entirely on a left-out GT: ignored
    pred = np.array([4, 4, 4, 4, 4, 7, -1, -1])
    q = instance_quality(pred, gt, min_size=2)
    assert q.n_gt == 1 and q.n_pred == 1
    assert q.best_iou == {0: 1.0} and q.ap50 == 1.0
    # without the filter, GT 1 counts and pred 7 matches it
    q1 = instance_quality(pred, gt)
    assert q1.n_gt == 2 and q1.n_pred == 2 and q1.ap50 == 1.0

    # pred 7 now half on the left-out GT, half on unlabelled GT: 1/2 is not > 1/2, so it
    # stays and is a false positive. Ranked 7 (FP) then 4 (TP): precision 0, 1/2 ->
    # interpolated 1/2, 1/2 -> AP = 1/2 (one recall step of 1 at precision 1/2)
    pred2 = np.array([4, 4, 4, 4, 4, 7, 7, -1])
    q2 = instance_quality(pred2, gt, min_size=2, scores={4: 0.1, 7: 0.9})
    assert q2.n_pred == 2
    assert q2.ap50 == 0.5
    # pred 7 with 2 of its 3 elements on the left-out GT 1 (size 2 < 3): ignored
    gt3 = np.array([0, 0, 0, 0, 0, 1, 1, -1])
    pred3 = np.array([4, 4, 4, 4, 4, 7, 7, 7])
    q3 = instance_quality(pred3, gt3, min_size=3, scores={4: 0.1, 7: 0.9})
    assert q3.n_gt == 1 and q3.n_pred == 1 and q3.ap50 == 1.0


def test_ignore_ids() -> None:
    gt = np.array([0, 0, 0, 1, 1, 1, 2, 2])  # ignore GT 2 (say the floor)
    pred = np.array([5, 5, 5, 6, 6, 6, 8, 8])
    q = instance_quality(pred, gt, ignore=[2])
    assert q.n_gt == 2 and q.n_pred == 2
    assert set(q.best_iou) == {0, 1} and q.ap50 == 1.0
    # a prediction merging GT 1 and the ignored GT 2 (3 of 5 elements on GT 2): ignored
    pred2 = np.array([5, 5, 5, 6, 6, 8, 8, 8])
    q2 = instance_quality(pred2, gt, ignore=[2])
    assert q2.n_pred == 2  # 5 and 6 stay, 8 is ignored
    # GT 1: best with 6 at 2/3, pred 8 (ignored) does not count
    assert close(q2.best_iou[1], 2 / 3) and q2.matched[1] == 6


def test_weights() -> None:
    # GT 1 = elements 0,1,2 with weights 1,2,3 (weight 6)
    # pred 5 = elements 2,3 with weights 3,4 (weight 7; element 3 is unlabelled in GT)
    # weighted IoU = 3 / (6 + 7 - 3) = 3/10; unweighted 1 / (3 + 2 - 1) = 1/4
    gt = np.array([1, 1, 1, -1])
    pred = np.array([-1, -1, 5, 5])
    w = np.array([1.0, 2.0, 3.0, 4.0])
    q = instance_quality(pred, gt, weights=w)
    assert close(q.best_iou[1], 0.3) and close(q.mean_best_iou, 0.3)
    assert q.ap50 == 0.0 and q.ap25 == 1.0
    q0 = instance_quality(pred, gt)
    assert q0.best_iou[1] == 0.25 and q0.ap25 == 1.0

    # min_size is a weight when weights are given: GT 1 weighs 6 < 7, left out
    q7 = instance_quality(pred, gt, weights=w, min_size=7)
    assert q7.n_gt == 0 and math.isnan(q7.ap50)
    # GT 1 has 3 elements >= 3 without weights, but weighs 0.6 < 3 with weights / 10
    assert instance_quality(pred, gt, min_size=3).n_gt == 1
    assert instance_quality(pred, gt, weights=w / 10, min_size=3).n_gt == 0


def test_errors() -> None:
    with pytest.raises(ValueError, match=r"\(3,\).*\(4,\)"):
        instance_quality(np.zeros(3, int), np.zeros(4, int))
    with pytest.raises(ValueError, match="integer"):
        instance_quality(np.zeros(3), np.zeros(3, int))
    with pytest.raises(ValueError, match="integer"):
        instance_quality(np.zeros(3, int), np.zeros(3, bool))
    with pytest.raises(ValueError, match="finite"):
        instance_quality(np.zeros(3, int), np.zeros(3, int), weights=[1.0, np.nan, 1.0])
    with pytest.raises(ValueError, match="non-negative"):
        instance_quality(np.zeros(3, int), np.zeros(3, int), weights=[1.0, -1.0, 1.0])
    with pytest.raises(ValueError, match="shape"):
        instance_quality(np.zeros(3, int), np.zeros(3, int), weights=[1.0, 1.0])
    with pytest.raises(ValueError, match="scores"):
        instance_quality(np.array([0, 1]), np.array([0, 1]), scores={0: 1.0})
    with pytest.raises(ValueError, match="finite"):
        instance_quality(np.array([0, 1]), np.array([0, 1]), scores={0: 1.0, 1: math.nan})
    with pytest.raises(ValueError, match="min_size"):
        instance_quality(np.array([0, 1]), np.array([0, 1]), min_size=-1)


def test_to_json() -> None:
    q = instance_quality(np.array([0, 0, 1, 1]), np.array([4, 4, 4, 4]))
    assert isinstance(q, InstanceQuality)
    j = q.to_json()
    assert j == {
        "n_gt": 1,
        "n_pred": 2,
        "mean_best_iou": 0.5,
        "ap50": 1.0,
        "ap25": 1.0,
        # two halves: IoU 0.5 is no match (it must exceed 0.5), and the object is split
        "pq": 0.0,
        "sq": None,
        "rq": 0.0,
        "split": 1,
        "merged": 0,
        "missed": 1,
        "extra": 2,
        "panoptic_min_size": 1,
        "void": "ignored",
        "best_iou": {"4": 0.5},
        "matched": {"4": 0},
    }
    assert json.loads(json.dumps(j, allow_nan=False)) == j


# -- property check against a slow reference ---------------------------------------------


def evaluated_sets(
    pred: list[int], gt: list[int], min_size: int, ignore: set[int]
) -> tuple[dict[int, set[int]], dict[int, set[int]]]:
    """The evaluated GT and predicted instances as sets of element indices (the module
    docstring's ``min_size``, ``ignore`` and left-out rules)."""
    gt_sets: dict[int, set[int]] = {}
    pred_sets: dict[int, set[int]] = {}
    for i, (p, g) in enumerate(zip(pred, gt)):
        if g >= 0:
            gt_sets.setdefault(g, set()).add(i)
        if p >= 0:
            pred_sets.setdefault(p, set()).add(i)
    left_out = {g for g, s in gt_sets.items() if len(s) < min_size or g in ignore}
    left_out_elems = set().union(*(gt_sets[g] for g in left_out))
    gts = {g: s for g, s in gt_sets.items() if g not in left_out}
    preds = {p: s for p, s in pred_sets.items() if not len(s & left_out_elems) > len(s) / 2}
    return gts, preds


def reference(
    pred: list[int],
    gt: list[int],
    scores: dict[int, float] | None,
    min_size: int,
    ignore: set[int],
) -> tuple[int, int, float, float, float]:
    """(n_gt, n_pred, mean best IoU, AP50, AP25) with plain Python sets."""
    gts, preds = evaluated_sets(pred, gt, min_size, ignore)

    def iou(a: set[int], b: set[int]) -> float:
        return len(a & b) / len(a | b)

    best = [max((iou(s, ps) for ps in preds.values()), default=0.0) for s in gts.values()]
    mean_best = sum(best) / len(best) if best else math.nan

    def ap(t: float) -> float:
        if not gts:
            return math.nan
        key = (lambda p: (-len(preds[p]), p)) if scores is None else (lambda p: (-scores[p], p))
        taken: set[int] = set()
        tps = []
        for p in sorted(preds, key=key):
            cands = [(iou(gts[g], preds[p]), -g, g) for g in gts if g not in taken]
            cands = [c for c in cands if c[0] >= t and c[0] > 0]
            if cands:
                taken.add(max(cands)[2])
            tps.append(bool(cands))
        # VOC all-points interpolation
        rec, prec, n_tp = [], [], 0
        for k, tp in enumerate(tps, start=1):
            n_tp += tp
            rec.append(n_tp / len(gts))
            prec.append(n_tp / k)
        mrec = [0.0, *rec, 1.0]
        mpre = [0.0, *prec, 0.0]
        for i in range(len(mpre) - 2, -1, -1):
            mpre[i] = max(mpre[i], mpre[i + 1])
        return sum(
            (mrec[i + 1] - mrec[i]) * mpre[i + 1]
            for i in range(len(mrec) - 1)
            if mrec[i + 1] != mrec[i]
        )

    return len(gts), len(preds), mean_best, ap(0.5), ap(0.25)


@pytest.mark.parametrize("seed", range(40))
def test_against_reference(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = int(rng.integers(0, 60))
    n_gt_labels = int(rng.integers(1, 7))
    gt = rng.integers(-1, n_gt_labels, size=n)
    # predictions: a noisy copy of the GT through a relabelling, or plain random labels
    if seed % 2:
        pred = rng.integers(-1, int(rng.integers(1, 9)), size=n)
    else:
        perm = rng.permutation(20)
        pred = np.where(gt >= 0, perm[np.maximum(gt, 0)], -1)
        noise = rng.random(n) < 0.3
        pred[noise] = rng.integers(-1, 20, size=int(noise.sum()))
    min_size = int(rng.integers(0, 4))
    ignore = {int(rng.integers(0, n_gt_labels))} if seed % 3 == 0 else set()
    pred_ids = sorted({int(p) for p in pred if p >= 0})
    scores = None
    if seed % 4 == 1:
        # few distinct values, so ties occur
        scores = {p: float(rng.integers(0, 3)) for p in pred_ids}

    q = instance_quality(pred, gt, scores=scores, min_size=min_size, ignore=ignore)
    n_gt, n_pred, mean_best, ap50, ap25 = reference(
        pred.tolist(), gt.tolist(), scores, min_size, ignore
    )
    assert (q.n_gt, q.n_pred) == (n_gt, n_pred)
    for got, want in ((q.mean_best_iou, mean_best), (q.ap50, ap50), (q.ap25, ap25)):
        assert (math.isnan(got) and math.isnan(want)) or close(got, want), (got, want)


def panoptic_reference(
    pred: list[int], gt: list[int], min_size: int, ignore: set[int], void: str = "counted"
) -> tuple[float, float, float, int, int, int, int]:
    """(PQ, SQ, RQ, split, merged, missed, extra) with plain Python sets; with ``void``
    "ignored", Kirillov et al.'s rules: the unlabelled elements leave each predicted set
    before its IoU, and a predicted set more than half unlabelled is no false positive."""
    gts, preds = evaluated_sets(pred, gt, min_size, ignore)
    unlabelled = {i for i, g in enumerate(gt) if g < 0} if void == "ignored" else set()
    matches = [
        len(gs & ps) / len(gs | (ps - unlabelled))
        for gs in gts.values()
        for ps in preds.values()
        if len(gs & ps) / len(gs | (ps - unlabelled)) > 0.5
    ]
    counted = [ps for ps in preds.values() if not len(ps & unlabelled) > len(ps) / 2]
    tp, fn, fp = len(matches), len(gts) - len(matches), len(counted) - len(matches)
    denom = tp + fp / 2 + fn / 2
    sq = sum(matches) / tp if tp else math.nan
    rq = tp / denom if denom else math.nan
    pq = (sq * rq if tp else 0.0) if denom else math.nan
    split = sum(
        1 for gs in gts.values() if sum(len(gs & ps) >= 0.2 * len(gs) for ps in preds.values()) >= 2
    )
    merged = sum(
        1
        for ps in preds.values()
        if sum(len(gs & ps) >= 0.2 * len(gs) > 0 for gs in gts.values()) >= 2
    )
    return pq, sq, rq, split, merged, fn, fp


@pytest.mark.parametrize("void", ["ignored", "counted"])
@pytest.mark.parametrize("seed", range(40))
def test_panoptic_quality_against_reference(seed: int, void: Void) -> None:
    rng = np.random.default_rng(1000 + seed)
    n = int(rng.integers(0, 80))
    gt = rng.integers(-1, int(rng.integers(1, 7)), size=n)
    if seed % 2:
        pred = rng.integers(-1, int(rng.integers(1, 9)), size=n)
    else:
        # a relabelled copy with some objects cut in two and others joined
        pred = np.where(gt >= 0, (gt * 7) % 5, -1)
        cut = rng.random(n) < 0.25
        pred[cut] = pred[cut] + 10
    min_size = int(rng.integers(0, 4))
    ignore = {0} if seed % 3 == 0 else set()
    q = instance_quality(pred, gt, min_size=min_size, ignore=ignore, void=void)
    assert q.void == void
    want = panoptic_reference(pred.tolist(), gt.tolist(), min_size, ignore, void)
    got = (q.pq, q.sq, q.rq, q.split, q.merged, q.missed, q.extra)
    for a, b in zip(got, want, strict=True):
        assert (math.isnan(a) and math.isnan(b)) or close(a, b), (got, want)


def test_panoptic_counts_a_split_and_a_merge() -> None:
    gt = np.array([0] * 10 + [1] * 10 + [2] * 10)
    split = instance_quality(np.array([0] * 5 + [1] * 5 + [2] * 10 + [3] * 10), gt)
    assert (split.split, split.merged, split.missed, split.extra) == (1, 0, 1, 2)
    assert close(split.rq, 2 / 3.5) and split.sq == 1.0 and close(split.pq, 2 / 3.5)
    merged = instance_quality(np.array([0] * 20 + [1] * 10), gt)
    assert (merged.split, merged.merged, merged.missed, merged.extra) == (0, 1, 2, 1)
    assert close(merged.pq, 1 / 2.5)
    exact = instance_quality(gt, gt)
    assert (exact.pq, exact.sq, exact.rq, exact.split, exact.merged) == (1.0, 1.0, 1.0, 0, 0)


def test_panoptic_quality_leaves_out_what_nobody_labelled() -> None:
    """Kirillov et al.'s void rules: a predicted instance is matched on its labelled part, and
    one mostly over unlabelled elements is no false positive; the mean best IoU and AP keep
    the unlabelled elements in the union (ScanNet's convention)."""
    gt = np.array([0] * 10 + [-1] * 8 + [1] * 10 + [-1] * 6)
    # object 0 with 8 unannotated elements beside it; object 1 exactly; an entity of 6
    # unannotated elements
    pred = np.array([0] * 18 + [1] * 10 + [2] * 6)
    ignored = instance_quality(pred, gt)
    assert (ignored.pq, ignored.sq, ignored.rq) == (1.0, 1.0, 1.0)
    assert (ignored.missed, ignored.extra, ignored.void) == (0, 0, "ignored")
    counted = instance_quality(pred, gt, void="counted")
    # object 0: IoU 10 / 18, still a match; the unannotated entity is a false positive
    assert (counted.missed, counted.extra) == (0, 1)
    assert close(counted.sq, (10 / 18 + 1) / 2) and close(counted.rq, 2 / 2.5)
    assert close(ignored.mean_best_iou, counted.mean_best_iou)
    assert close(counted.mean_best_iou, (10 / 18 + 1) / 2)
    # a half-void entity that holds too little of its object: missed, and it is no match,
    # but as it is not more than half void it still counts as a false positive
    half = np.array([0] * 4 + [-1] * 6 + [0] * 4 + [-1] * 4 + [1] * 10 + [-1] * 6)
    half_q = instance_quality(half, gt)
    assert (half_q.missed, half_q.extra) == (1, 1)
    weighted = instance_quality(pred, gt, weights=np.ones(gt.size))
    assert (weighted.pq, weighted.extra) == (1.0, 0)
    with pytest.raises(ValueError, match="void must be one of ignored, counted, got 'none'"):
        instance_quality(pred, gt, void="none")  # type: ignore[arg-type]
    assert scene_quality(pred, gt, panoptic_min_size=1, void="counted").extra == 1


def test_large_identical() -> None:
    rng = np.random.default_rng(0)
    gt = rng.integers(-1, 1000, size=1_000_000)
    relabel = rng.permutation(1000) + 5
    pred = np.where(gt >= 0, relabel[np.maximum(gt, 0)], -1)
    q = instance_quality(pred, gt)
    assert q.n_gt == 1000 and q.n_pred == 1000
    assert q.mean_best_iou == 1.0 and q.ap50 == 1.0 and q.ap25 == 1.0
    qw = instance_quality(pred, gt, weights=rng.random(gt.size))
    assert qw.n_gt == 1000 and qw.n_pred == 1000
    assert close(qw.mean_best_iou, 1.0) and qw.ap50 == 1.0 and qw.ap25 == 1.0
