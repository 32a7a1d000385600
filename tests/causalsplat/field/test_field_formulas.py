"""The feature field's formulas against hand-computed values, and their extreme cases."""

from __future__ import annotations

import math

import numpy as np
import pytest

from causalsplat.field import FieldConfig, FieldConfigError, mask_features, mask_weights
from causalsplat.field.train import _view_terms, contrastive_loss
from causalsplat.field.weights import view_masks
from causalsplat.masks import MaskSet

W_MIN = 0.4


def test_spatial_weights_of_a_3x3_square() -> None:
    mask = np.ones((3, 3), dtype=bool)
    w = mask_weights(mask, w_min=W_MIN, eps=1e-12)
    # centre (1, 1): d = 0; edge midpoints: d = 1; corners: d = d_max = sqrt(2)
    assert w[1, 1] == pytest.approx(1.0)
    assert w[0, 1] == pytest.approx(W_MIN + (1 - W_MIN) * (1 - 1 / math.sqrt(2)))
    assert w[0, 0] == pytest.approx(W_MIN)
    assert np.allclose(w, w.T) and np.allclose(w, w[::-1, ::-1])


def test_weights_are_zero_outside_and_centre_is_the_pixel_mean() -> None:
    mask = np.zeros((5, 7), dtype=bool)
    mask[1, 1:6] = True  # a 1x5 bar: centre is pixel (1, 3)
    w = mask_weights(mask, w_min=W_MIN)
    assert np.all(w[~mask] == 0)
    assert w[1, 3] == pytest.approx(1.0)
    assert w[1, 1] == pytest.approx(W_MIN, abs=1e-5) and w[1, 5] == pytest.approx(W_MIN, abs=1e-5)
    assert w[1, 2] == pytest.approx(W_MIN + (1 - W_MIN) * 0.5, abs=1e-5)


def test_one_pixel_mask_has_d_max_zero_and_weight_one() -> None:
    mask = np.zeros((4, 4), dtype=bool)
    mask[2, 3] = True
    w = mask_weights(mask, w_min=W_MIN, eps=1e-6)
    assert w[2, 3] == 1.0 and w.sum() == 1.0


def test_empty_mask_and_ablation_weightings() -> None:
    assert not mask_weights(np.zeros((3, 3), dtype=bool)).any()
    mask = np.ones((6, 6), dtype=bool)
    assert np.all(mask_weights(mask, weighting="average") == 1.0)
    rnd = mask_weights(mask, weighting="random", w_min=W_MIN, rng=np.random.default_rng(0))
    assert rnd.min() >= W_MIN and rnd.max() <= 1.0 and np.unique(rnd).size == 36
    with pytest.raises(FieldConfigError, match="random generator"):
        mask_weights(mask, weighting="random")
    with pytest.raises(FieldConfigError, match="unknown weighting"):
        mask_weights(mask, weighting="gaussian")
    with pytest.raises(FieldConfigError, match=r"\(H, W\)"):
        mask_weights(np.ones(5, dtype=bool))


def test_mask_feature_is_the_normalised_weighted_sum_of_unit_pixel_features() -> None:
    masks = MaskSet("v", np.array([[[True, True, False]]]))
    vm = view_masks(masks, 0, FieldConfig(weighting="average", min_mask_pixels=1),
                    np.random.default_rng(0))  # fmt: skip
    # pixel features (3, 0) and (0, 0.5): unit vectors e1 and e2, equal weights
    fmap = np.array([[3.0, 0.0], [0.0, 0.5], [7.0, 7.0]])
    p = mask_features(fmap, vm)
    assert p.shape == (1, 2) and p.dtype == np.float32
    np.testing.assert_allclose(p[0], [1 / math.sqrt(2), 1 / math.sqrt(2)], rtol=1e-6)
    # a mask over pixels that render nothing gets a zero feature, not NaN
    assert np.all(mask_features(np.zeros((3, 2)), vm) == 0)


def test_view_masks_drop_small_masks_and_invalid_pixels() -> None:
    m = np.zeros((3, 4, 4), dtype=bool)
    m[0, :2, :2] = True  # 4 px
    m[1, 3, 3] = True  # 1 px: below min_mask_pixels = 2
    m[2, 2:, :] = True  # 8 px, half of them invalid below
    valid = np.ones((4, 4), dtype=bool)
    valid[3, :] = False
    vm = view_masks(MaskSet("v", m), 5, FieldConfig(min_mask_pixels=2),
                    np.random.default_rng(0), valid=valid)  # fmt: skip
    assert vm.view == 5 and vm.mask_index.tolist() == [0, 2]
    assert vm.weights.shape == (2, 16)
    assert sorted(vm.pixels.tolist()) == [0, 1, 4, 5, 8, 9, 10, 11]
    with pytest.raises(FieldConfigError, match="valid-pixel map"):
        view_masks(MaskSet("v", m), 0, FieldConfig(), np.random.default_rng(0),
                   valid=np.ones((2, 2), dtype=bool))  # fmt: skip
    # a view where SAM found nothing: no masks, no rows (it crashed the build)
    none = view_masks(MaskSet("v", np.zeros((0, 4, 4), dtype=bool)), 1, FieldConfig(),
                      np.random.default_rng(0))  # fmt: skip
    assert none.mask_index.tolist() == [] and none.weights.shape[0] == 0


def _loss(masks: np.ndarray, feats: np.ndarray, **cfg: float) -> float:
    config = FieldConfig(weighting="average", min_mask_pixels=1, **cfg)  # type: ignore[arg-type]
    vm = view_masks(MaskSet("v", masks), 0, config, np.random.default_rng(0))
    terms = _view_terms(vm)
    rendered = np.asarray(feats, dtype=np.float64)[terms.pixels]
    return contrastive_loss(rendered, terms, config, np.random.default_rng(0))


def test_contrastive_loss_hand_values() -> None:
    two = np.array([[[True, False]], [[False, True]]])
    # orthogonal unit features, one pixel per mask: both terms vanish
    assert _loss(two, np.array([[1.0, 0.0], [0.0, 1.0]])) == pytest.approx(0.0, abs=1e-12)
    # cosine 0.6 > tau = 0.5: each pixel is a hard negative of the other mask
    fe = np.array([[1.0, 0.0], [0.6, 0.8]])
    assert _loss(two, fe) == pytest.approx(0.6 - 0.03)
    assert _loss(two, fe, negative_weight=2.0) == pytest.approx(2 * (0.6 - 0.03))
    # one mask over both orthogonal pixels: L_pos = 1 - |e1 + e2| / 2
    one = np.array([[[True, True]]])
    assert _loss(one, np.array([[2.0, 0.0], [0.0, 5.0]])) == pytest.approx(1 - math.sqrt(2) / 2)


def test_overlapping_masks_are_not_negatives_of_each_other() -> None:
    nested = np.array([[[True, True]], [[True, False]]])  # mask 1 inside mask 0
    # pixel features orthogonal: with nesting, no negatives at all; only positives count
    got = _loss(nested, np.array([[1.0, 0.0], [0.0, 1.0]]))
    assert got == pytest.approx((1 - math.sqrt(2) / 2 + 0.0) / 2)


@pytest.mark.parametrize(
    ("name", "value"),
    [("feature_dim", 1), ("w_min", 1.5), ("w_min", float("nan")), ("eps", 0.0),
     ("weighting", "median"), ("init", "zeros"), ("iterations", -1), ("margin", 1.0),
     ("learning_rate", 0.0), ("pixels_per_step", -1), ("min_mask_pixels", 0),
     ("min_pixel_alpha", 1.0), ("seed", -1)],
)  # fmt: skip
def test_field_config_rejects_out_of_range_values(name: str, value: object) -> None:
    with pytest.raises(FieldConfigError, match=f"FieldConfig.{name}"):
        FieldConfig(**{name: value})  # type: ignore[arg-type]
