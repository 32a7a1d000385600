"""The SAM-like noise model: each effect on its own, determinism, strength 0 = exact GT."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from causalsplat.masks import (
    InvalidNoiseError,
    MaskSet,
    NoiseConfig,
    masks_from_id_render,
    perturb_masks,
)

OFF = NoiseConfig(p_drop=0, p_merge=0, p_split=0, p_jitter=0, fragment_rate=0)


def _grid_view(h: int = 60, w: int = 80) -> MaskSet:
    """Six touching rectangles (ids 0..5) on a background."""
    ids = np.full((h, w), -1)
    for k in range(6):
        r, c = divmod(k, 3)
        ids[5 + 25 * r : 5 + 25 * (r + 1), 5 + 23 * c : 5 + 23 * (c + 1)] = k
    return masks_from_id_render(ids, {k: f"cat{k}" for k in range(6)}, view="v")


def _only(**rates: float) -> NoiseConfig:
    from dataclasses import replace

    return replace(OFF, **rates)


def test_strength_zero_returns_the_exact_masks() -> None:
    gt = _grid_view()
    out = perturb_masks(gt, 0.0, np.random.default_rng(0))
    assert out.equals(gt)


def test_same_seed_same_masks_other_seed_other_masks() -> None:
    gt = _grid_view()
    a = perturb_masks(gt, 2.0, np.random.default_rng(5))
    b = perturb_masks(gt, 2.0, np.random.default_rng(5))
    c = perturb_masks(gt, 2.0, np.random.default_rng(6))
    assert a.equals(b)
    assert not a.equals(c)
    assert a.scores is not None and a.labels is not None and a.ids is None


def test_drop_removes_masks() -> None:
    out = perturb_masks(_grid_view(), 1.0, np.random.default_rng(0), _only(p_drop=1.0))
    assert out.n == 0 and out.masks.shape == (0, 60, 80)


def test_merge_joins_adjacent_masks_into_their_union() -> None:
    gt = _grid_view()
    out = perturb_masks(gt, 1.0, np.random.default_rng(1), _only(p_merge=1.0))
    assert out.labels is not None and out.scores is not None
    used: list[int] = []
    merged = 0
    for mask, label, score in zip(out.masks, out.labels, out.scores, strict=True):
        parts = [i for i in range(gt.n) if np.any(mask & gt.masks[i])]
        used += parts
        np.testing.assert_array_equal(mask, np.any(gt.masks[parts], axis=0))
        assert label in {f"cat{i}" for i in parts}
        if len(parts) == 2:
            merged += 1
            assert score == pytest.approx(0.75)
            grown = ndimage.binary_dilation(gt.masks[parts[0]], iterations=2)
            assert np.any(grown & gt.masks[parts[1]])  # only adjacent masks merge
        else:
            assert len(parts) == 1 and score == 1.0
    assert sorted(used) == list(range(gt.n))  # each GT mask in exactly one output mask
    assert merged >= 2


def test_split_cuts_masks_into_disjoint_parts_covering_the_original() -> None:
    gt = _grid_view()
    out = perturb_masks(gt, 1.0, np.random.default_rng(2), _only(p_split=1.0))
    assert gt.n * 2 <= out.n <= gt.n * 3
    assert out.labels is not None
    for i in range(gt.n):
        parts = [k for k in range(out.n) if np.any(out.masks[k] & gt.masks[i])]
        assert 2 <= len(parts) <= 3
        union = np.any(out.masks[parts], axis=0)
        np.testing.assert_array_equal(union, gt.masks[i])
        assert out.masks[parts].sum() == gt.masks[i].sum()  # disjoint
        assert {out.labels[k] for k in parts} == {f"cat{i}"}


def test_jitter_only_moves_the_boundary_band() -> None:
    gt = _grid_view()
    amplitude = 2.0
    cfg = _only(p_jitter=1.0, jitter_px=amplitude)
    out = perturb_masks(gt, 1.0, np.random.default_rng(3), cfg)
    assert out.n == gt.n
    changed_any = False
    for before, after in zip(gt.masks, out.masks, strict=True):
        changed = before ^ after
        changed_any |= bool(changed.any())
        inside = ndimage.distance_transform_edt(before)
        outside = ndimage.distance_transform_edt(~before)
        band = np.where(before, inside - 0.5, outside - 0.5) <= amplitude
        assert not np.any(changed & ~band)
        iou = (before & after).sum() / (before | after).sum()
        assert iou > 0.7
    assert changed_any


def test_fragments_are_small_extra_masks_labelled_object() -> None:
    gt = _grid_view()
    out = perturb_masks(gt, 1.0, np.random.default_rng(4), _only(fragment_rate=5.0))
    assert out.n > gt.n and out.labels is not None and out.scores is not None
    for k in range(gt.n, out.n):
        assert out.labels[k] == "object"
        assert 0.3 <= out.scores[k] <= 0.6
        assert out.masks[k].sum() <= np.pi * (0.06 * 60) ** 2 + 4
    np.testing.assert_array_equal(out.masks[: gt.n], gt.masks)


def test_noise_grows_with_strength() -> None:
    gt = _grid_view()

    def mean_best_iou(strength: float) -> float:
        scores = []
        for seed in range(20):
            out = perturb_masks(gt, strength, np.random.default_rng(seed))
            for m in gt.masks:
                inter = (out.masks & m).sum(axis=(1, 2)) if out.n else np.zeros(1)
                union = (out.masks | m).sum(axis=(1, 2)) if out.n else np.ones(1)
                scores.append(float((inter / union).max()))
        return float(np.mean(scores))

    ious = [mean_best_iou(s) for s in (0.0, 0.5, 1.0, 3.0)]
    assert ious[0] == 1.0
    assert ious[0] > ious[1] > ious[2] > ious[3]


def test_unlabelled_masks_stay_unlabelled() -> None:
    gt = MaskSet("v", _grid_view().masks)
    out = perturb_masks(gt, 3.0, np.random.default_rng(0))
    assert out.labels is None and out.scores is not None


@pytest.mark.parametrize("strength", [-0.1, float("nan"), float("inf"), "x"])
def test_bad_strength_is_refused(strength: object) -> None:
    with pytest.raises(InvalidNoiseError, match="strength"):
        perturb_masks(_grid_view(), strength, np.random.default_rng(0))  # type: ignore[arg-type]


def test_bad_config_is_refused() -> None:
    with pytest.raises(InvalidNoiseError, match="p_drop"):
        NoiseConfig(p_drop=1.5)
    with pytest.raises(InvalidNoiseError, match="fragment_radius"):
        NoiseConfig(fragment_radius=(0.1, 0.05))
