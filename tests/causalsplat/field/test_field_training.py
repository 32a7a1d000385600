"""The training step's parts: Adam and the loss gradient against torch, sampled terms."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from causalsplat.field import FieldConfig, FieldConfigError
from causalsplat.field.adam import Adam
from causalsplat.field.train import _view_terms, _ViewTerms, contrastive_loss_and_grad, mask_overlap
from causalsplat.field.weights import view_masks
from causalsplat.masks import MaskSet


@pytest.mark.parametrize("compiled", [False, True])
def test_adam_follows_torch_adam_over_many_steps(compiled: bool) -> None:
    if compiled:
        pytest.importorskip("numba")
    rng = np.random.default_rng(0)
    ours = rng.standard_normal((300, 16)).astype(np.float32)
    theirs = torch.tensor(ours.copy(), requires_grad=True)
    mine, ref = Adam(ours, lr=0.02, compiled=compiled), torch.optim.Adam([theirs], lr=0.02)
    for step in range(200):
        grad = (rng.standard_normal((300, 16)) * 10.0 ** (step % 5 - 2)).astype(np.float32)
        grad[step % 300] = 0.0  # 1e-2 .. 1e2, and a row with no gradient
        theirs.grad = torch.from_numpy(grad.copy())
        mine.step(grad)
        ref.step()
    np.testing.assert_allclose(ours, theirs.detach().numpy(), rtol=1e-5, atol=1e-6)
    assert mine.steps == 200 and np.abs(ours).sum() > 0


def test_compiled_adam_gives_numpys_bits() -> None:
    """The compiled update does numpy's float32 operations in numpy's order."""
    pytest.importorskip("numba")
    rng = np.random.default_rng(1)
    start = rng.standard_normal((257, 16)).astype(np.float32)
    fast, slow = start.copy(), start.copy()
    opt_fast, opt_slow = Adam(fast, lr=0.05, compiled=True), Adam(slow, lr=0.05, compiled=False)
    for step in range(60):
        grad = (rng.standard_normal((257, 16)) * 10.0 ** (step % 7 - 3)).astype(np.float32)
        grad[step % 257] = 0.0
        opt_fast.step(grad)
        opt_slow.step(grad)
    np.testing.assert_array_equal(fast, slow)
    np.testing.assert_array_equal(opt_fast.m, opt_slow.m)
    np.testing.assert_array_equal(opt_fast.v, opt_slow.v)
    assert not np.array_equal(fast, start)


def test_adam_rejects_what_it_cannot_optimise() -> None:
    with pytest.raises(FieldConfigError, match="float32 numpy array"):
        Adam(np.zeros(3), lr=0.1)
    with pytest.raises(FieldConfigError, match="lr must be > 0"):
        Adam(np.zeros(3, np.float32), lr=0.0)
    frozen = np.zeros(3, np.float32)
    frozen.flags.writeable = False
    with pytest.raises(FieldConfigError, match="writeable"):
        Adam(frozen, lr=0.1)
    with pytest.raises(FieldConfigError, match=r"gradient of shape \(2,\)"):
        Adam(np.zeros(3, np.float32), lr=0.1).step(np.zeros(2, np.float32))


def _torch_loss(f: torch.Tensor, terms: _ViewTerms, keep: torch.Tensor, config: FieldConfig
                ) -> torch.Tensor:  # fmt: skip
    """The module docstring's loss in torch, with the kept negatives given."""
    unit = f / f.norm(dim=1, keepdim=True).clamp_min(1e-8)
    w = torch.from_numpy(terms.weights).to(f.dtype)
    summed = w @ unit
    length = summed.norm(dim=1)
    positive = 1.0 - length / torch.from_numpy(terms.weight_sums).to(f.dtype).clamp_min(1e-12)
    proto = summed / length.clamp_min(1e-12)[:, None]
    sim = unit @ proto.T
    hinge = torch.relu(sim - config.margin) * keep
    negative = hinge.sum(dim=0) / keep.sum(dim=0).clamp_min(1).to(f.dtype)
    return (positive + config.negative_weight * negative).mean()


@pytest.mark.parametrize("seed", range(4))
def test_loss_gradient_is_torch_autograd_of_the_same_loss(seed: int) -> None:
    maskset, _ = _view(seed)
    config = FieldConfig(min_mask_pixels=1, negative_weight=0.7, margin=0.1, hard_negative=0.3)
    vm = view_masks(maskset, 0, config, np.random.default_rng(0))
    terms = _view_terms(vm)
    rng = np.random.default_rng(seed)
    f = rng.standard_normal((vm.pixels.size, 5))
    f[0] *= 1e-10  # a pixel below the norm clamp
    f[1] = 0.0
    loss, grad = contrastive_loss_and_grad(f, terms, config, np.random.default_rng(7))
    # the kept negatives of that call, drawn again from the same generator
    unit = f / np.maximum(np.linalg.norm(f, axis=1), 1e-8)[:, None]
    summed = terms.weights @ unit
    proto = summed / np.maximum(np.linalg.norm(summed, axis=1), 1e-12)[:, None]
    sim = unit @ proto.T
    u = np.random.default_rng(7).random(sim.shape, dtype=np.float32)
    ratio = terms.n_pos / np.maximum(terms.negative.sum(axis=0), 1)
    keep = terms.negative & ((u < ratio[None, :]) | (sim > config.hard_negative))
    assert keep.any() and (~keep & terms.negative).any()
    ft = torch.tensor(f, requires_grad=True)
    ref = _torch_loss(ft, terms, torch.from_numpy(keep), config)
    ref.backward()
    assert loss == pytest.approx(float(ref.detach()), rel=1e-12)
    assert ft.grad is not None
    np.testing.assert_allclose(grad, ft.grad.numpy(), rtol=1e-9, atol=1e-12)
    assert np.abs(grad).max() > 1e-3


def _view(seed: int) -> tuple[MaskSet, np.ndarray]:
    rng = np.random.default_rng(seed)
    masks = np.zeros((6, 12, 16), dtype=bool)
    for i in range(6):  # rectangles: some nested, some overlapping, some apart
        y, x = rng.integers(0, 8), rng.integers(0, 12)
        masks[i, y : y + rng.integers(2, 5), x : x + rng.integers(2, 5)] = True
    masks[5] = False
    masks[5, 0, 0] = True  # one pixel: rarely in a sample
    return MaskSet("v", masks), rng.choice(12 * 16, 12 * 16, replace=False)


def test_masks_are_nested_when_they_share_more_than_the_share_of_the_smaller_one() -> None:
    masks = np.zeros((4, 20, 20), dtype=bool)
    masks[0, :, :11] = True  # the left half and one column: 220 px
    masks[1, :, 10:] = True  # the right half, 200 px: shares column 10 (20 px) with it
    masks[2, 2:8, 2:8] = True  # 36 px inside the left half: a part and its whole
    masks[3, 2:8, 8:14] = True  # 36 px: 18 in the left half, 24 in the right one
    vm = view_masks(MaskSet("v", masks), 0, FieldConfig(), np.random.default_rng(0))
    assert vm.n_masks == 4
    any_pixel = mask_overlap(vm)
    assert np.array_equal(any_pixel, mask_overlap(vm, 0.0))
    assert any_pixel[0].all() and any_pixel[1, 3] and not any_pixel[1, 2] and not any_pixel[2, 3]
    nested = mask_overlap(vm, 0.5)
    assert np.array_equal(nested, nested.T) and nested.diagonal().all()
    assert not nested[0, 1]  # neighbours: 20 of 200 px
    assert nested[0, 2]  # the part lies whole inside
    assert not nested[0, 3] and nested[1, 3]  # 18 of 36 is not more than half; 24 is
    assert mask_overlap(vm, 0.6)[1, 3] and not mask_overlap(vm, 0.7)[1, 3]  # 24 / 36
    assert np.array_equal(mask_overlap(vm, 1.0), np.eye(4, dtype=bool))


@pytest.mark.parametrize("seed", range(5))
def test_sampled_terms_are_the_full_terms_on_the_sample(seed: int) -> None:
    maskset, _ = _view(seed)
    config = FieldConfig(min_mask_pixels=1)
    vm = view_masks(maskset, 0, config, np.random.default_rng(0))
    full = _view_terms(vm)
    dense = vm.weights.toarray()[:, vm.pixels]
    np.testing.assert_array_equal(full.weights, dense)
    member = dense > 0
    overlap = (member.astype(int) @ member.T.astype(int)) > 0
    np.testing.assert_array_equal(mask_overlap(vm), overlap)
    blocked = np.array([[(member[:, p] & overlap[:, m]).any() for m in range(vm.n_masks)]
                        for p in range(vm.pixels.size)])  # fmt: skip
    np.testing.assert_array_equal(full.negative, ~blocked)
    rng = np.random.default_rng(seed)
    sample = np.sort(rng.choice(vm.pixels.size, vm.pixels.size // 3, replace=False))
    part = _view_terms(vm, sample, mask_overlap(vm))
    present = member[:, sample].any(axis=1)
    np.testing.assert_array_equal(part.pixels, vm.pixels[sample])
    np.testing.assert_array_equal(part.weights, dense[present][:, sample])
    np.testing.assert_array_equal(part.negative, ~blocked[sample][:, present])
    np.testing.assert_array_equal(part.n_pos, member[present][:, sample].sum(axis=1))
    np.testing.assert_allclose(part.weight_sums, dense[present][:, sample].sum(axis=1),
                               rtol=1e-6)  # fmt: skip
