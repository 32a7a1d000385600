"""The training step's parts: Adam against torch's, the sampled loss terms against the full ones."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from causalsplat.field import FieldConfig, FieldConfigError
from causalsplat.field.adam import Adam
from causalsplat.field.train import _view_terms, mask_overlap
from causalsplat.field.weights import view_masks
from causalsplat.masks import MaskSet


def test_adam_follows_torch_adam_over_many_steps() -> None:
    gen = torch.Generator().manual_seed(0)
    ours = torch.randn(300, 16, generator=gen, requires_grad=True)
    theirs = ours.detach().clone().requires_grad_(True)
    mine, ref = Adam(ours, lr=0.02), torch.optim.Adam([theirs], lr=0.02)
    for step in range(200):
        grad = torch.randn(300, 16, generator=gen) * 10.0 ** (step % 5 - 2)  # 1e-2 .. 1e2
        grad[step % 300] = 0.0
        ours.grad, theirs.grad = grad.clone(), grad.clone()
        mine.step()
        ref.step()
        mine.zero_grad()
        assert ours.grad is None
    torch.testing.assert_close(ours, theirs, rtol=1e-5, atol=1e-6)
    assert not torch.equal(ours, torch.zeros_like(ours))


def test_adam_rejects_what_it_cannot_optimise() -> None:
    with pytest.raises(FieldConfigError, match="float32 leaf"):
        Adam(torch.zeros(3, dtype=torch.float64, requires_grad=True), lr=0.1)
    with pytest.raises(FieldConfigError, match="lr must be > 0"):
        Adam(torch.zeros(3, requires_grad=True), lr=0.0)
    opt = Adam(torch.zeros(3, requires_grad=True), lr=0.1)
    opt.step()  # no gradient yet: nothing moves
    assert opt.steps == 0


def _view(seed: int) -> tuple[MaskSet, np.ndarray]:
    rng = np.random.default_rng(seed)
    masks = np.zeros((6, 12, 16), dtype=bool)
    for i in range(6):  # rectangles: some nested, some overlapping, some apart
        y, x = rng.integers(0, 8), rng.integers(0, 12)
        masks[i, y : y + rng.integers(2, 5), x : x + rng.integers(2, 5)] = True
    masks[5] = False
    masks[5, 0, 0] = True  # one pixel: rarely in a sample
    return MaskSet("v", masks), rng.choice(12 * 16, 12 * 16, replace=False)


@pytest.mark.parametrize("seed", range(5))
def test_sampled_terms_are_the_full_terms_on_the_sample(seed: int) -> None:
    maskset, _ = _view(seed)
    config = FieldConfig(min_mask_pixels=1)
    vm = view_masks(maskset, 0, config, np.random.default_rng(0))
    full = _view_terms(vm)
    dense = vm.weights.toarray()[:, vm.pixels]
    np.testing.assert_array_equal(full.weights.numpy(), dense)
    member = dense > 0
    overlap = (member.astype(int) @ member.T.astype(int)) > 0
    np.testing.assert_array_equal(mask_overlap(vm), overlap)
    blocked = np.array([[(member[:, p] & overlap[:, m]).any() for m in range(vm.n_masks)]
                        for p in range(vm.pixels.size)])  # fmt: skip
    np.testing.assert_array_equal(full.negative.numpy(), ~blocked)
    rng = np.random.default_rng(seed)
    sample = np.sort(rng.choice(vm.pixels.size, vm.pixels.size // 3, replace=False))
    part = _view_terms(vm, sample, mask_overlap(vm))
    present = member[:, sample].any(axis=1)
    np.testing.assert_array_equal(part.pixels.numpy(), vm.pixels[sample])
    np.testing.assert_array_equal(part.weights.numpy(), dense[present][:, sample])
    np.testing.assert_array_equal(part.negative.numpy(), ~blocked[sample][:, present])
    np.testing.assert_array_equal(part.n_pos.numpy(), member[present][:, sample].sum(axis=1))
    np.testing.assert_allclose(part.weight_sums.numpy(), dense[present][:, sample].sum(axis=1),
                               rtol=1e-6)  # fmt: skip
