"""Contrastive optimisation of per-Gaussian features through the cached-weight renderer (torch).

One step takes one view (views visited in a seeded random order, each once per epoch) and
``FieldConfig.pixels_per_step`` of its covered pixels, drawn uniformly without replacement
(all of them when 0 or when the view has fewer): render the features ``F = W f`` (P, C) at
those pixels only, normalise each, and for every mask ``m`` with a pixel among them, with
weights ``W_m``:

* prototype ``p_m = Norm(sum_x W_m(x) F̂(x))``;
* positive term ``L_pos(m) = sum_x W_m(x) (1 - F̂(x)·p_m) / sum_x W_m(x)``, which equals
  ``1 - |sum_x W_m(x) F̂(x)| / sum_x W_m(x)`` and is computed that way;
* negatives: covered pixels outside ``m`` and outside every mask that overlaps ``m``
  (nested or overlapping SAM masks are not pushed apart). With ``S(x) = F̂(x)·p_m``, a
  negative is kept when ``u < N_pos / N_neg`` (``u ~ U(0, 1)``: balances the counts) or
  ``S(x) > τ`` (hard negatives are always kept); ``L_neg(m)`` is the mean of
  ``max(0, S(x) - margin)`` over the kept ones;
* loss: mean over masks of ``L_pos + λ L_neg``, minimised by Adam on ``f``.

Sampling makes a step cost the same at any image size: on scene0000_00 (320x240, 81k
Gaussians) 8192 pixels a step took 11 ms against 35 ms for all of them, at equal instance
quality (docs/benchmarks.md).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import torch

from causalsplat.field.adam import Adam
from causalsplat.field.blas import single_threaded_blas
from causalsplat.field.config import FieldConfig
from causalsplat.field.weights import ViewMasks
from causalsplat.render.functional import render_features
from causalsplat.render.types import Contributors


@dataclass(frozen=True, slots=True)
class _ViewTerms:
    """Per-view constants of the loss (torch): see the module docstring."""

    pixels: torch.Tensor  # (P,) int64 covered pixels
    weights: torch.Tensor  # (M, P) float32 dense, W_m on the covered pixels
    weight_sums: torch.Tensor  # (M,) float32
    negative: torch.Tensor  # (P, M) bool, pixel may serve as a negative of mask m
    n_pos: torch.Tensor  # (M,) float32 pixels per mask


def mask_overlap(vm: ViewMasks) -> np.ndarray:
    """(M, M) bool: the masks of ``vm`` that share a pixel (each mask with itself)."""
    member = (vm.weights > 0).astype(np.float32)
    return np.asarray((member @ member.T).toarray() > 0)


def _view_terms(
    vm: ViewMasks, sample: np.ndarray | None = None, overlap: np.ndarray | None = None
) -> _ViewTerms:
    """The loss terms of ``vm`` on its covered pixels, or on ``vm.pixels[sample]``.

    With a sample, masks that have no pixel in it take no part. ``overlap``: the view's
    :func:`mask_overlap`, when the caller keeps it between steps.
    """
    pixels = vm.pixels if sample is None else vm.pixels[sample]
    if overlap is None:
        overlap = mask_overlap(vm)
    # Dense (M, P) weights, read off the mask CSR through a pixel -> column map: (M, P) is
    # the size of the (P, M) similarities the loss forms anyway, and a dense product (and
    # its gradient) costs a fraction of a sparse one.
    column = np.full(vm.n_pixels, -1, dtype=np.int64)
    column[pixels] = np.arange(pixels.shape[0])
    w = vm.weights
    cols = column[w.indices]
    hit = cols >= 0
    rows = np.repeat(np.arange(vm.n_masks), np.diff(w.indptr))
    weights = np.zeros((vm.n_masks, pixels.shape[0]), dtype=np.float32)
    weights[rows[hit], cols[hit]] = w.data[hit]
    member = weights > 0
    n_pos = member.sum(axis=1)
    # A pixel is no negative of mask m when it lies in a mask that overlaps m.
    blocked = (member.T.astype(np.float32) @ overlap.astype(np.float32)) > 0  # (P, M)
    if sample is not None and not n_pos.all():
        keep = n_pos > 0
        weights, n_pos, blocked = weights[keep], n_pos[keep], blocked[:, keep]
    return _ViewTerms(
        pixels=torch.from_numpy(pixels.astype(np.int64)),
        weights=torch.from_numpy(weights),
        weight_sums=torch.from_numpy(weights.sum(axis=1, dtype=np.float32)),
        negative=torch.from_numpy(~blocked),
        n_pos=torch.from_numpy(n_pos.astype(np.float32)),
    )


def contrastive_loss(
    f: torch.Tensor, terms: _ViewTerms, config: FieldConfig, generator: torch.Generator
) -> torch.Tensor:
    """The loss of one view (module docstring) from its (P, C) render at ``terms.pixels``."""
    unit = f / f.norm(dim=1, keepdim=True).clamp_min(1e-8)
    summed = terms.weights.to(f.dtype) @ unit  # (M, C)
    length = summed.norm(dim=1)
    positive = 1.0 - length / terms.weight_sums.to(f.dtype).clamp_min(1e-12)
    proto = summed / length.clamp_min(1e-12)[:, None]
    sim = unit @ proto.T  # (P, M)
    n_neg = terms.negative.sum(dim=0).to(sim.dtype)
    ratio = terms.n_pos.to(sim.dtype) / n_neg.clamp_min(1.0)
    u = torch.rand(sim.shape, generator=generator, dtype=sim.dtype)
    keep = terms.negative & ((u < ratio[None, :]) | (sim.detach() > config.hard_negative))
    hinge = torch.relu(sim - config.margin) * keep
    negative = hinge.sum(dim=0) / keep.sum(dim=0).clamp_min(1).to(sim.dtype)
    return (positive + config.negative_weight * negative).mean()


def train_features(
    contributors: Sequence[Contributors],
    masks: Sequence[ViewMasks],
    init: np.ndarray,
    config: FieldConfig,
    *,
    progress: Callable[[int], None] | None = None,
    threads: int | None = None,
) -> tuple[np.ndarray, tuple[float, ...]]:
    """Optimise ``init`` (N, C) for ``config.iterations`` steps; returns (features, losses).

    ``threads``: torch threads for the steps (``None``: torch's setting), restored after;
    numpy's BLAS runs on one thread meanwhile (:mod:`causalsplat.field.blas`).

    Views without usable masks are skipped. ``progress(k)`` is called after each step.
    Deterministic for a given ``config.seed`` (torch's CPU kernels are).
    """
    views = [i for i, vm in enumerate(masks) if vm.n_masks > 0 and vm.pixels.size > 0]
    feats = torch.tensor(np.asarray(init, dtype=np.float32), requires_grad=True)
    if not views or config.iterations == 0:
        return feats.detach().numpy().astype(np.float64), ()
    before = torch.get_num_threads()
    if threads is not None:
        torch.set_num_threads(threads)
    try:
        with single_threaded_blas():
            return _train(contributors, masks, views, feats, config, progress)
    finally:
        torch.set_num_threads(before)


def _train(
    contributors: Sequence[Contributors],
    masks: Sequence[ViewMasks],
    views: list[int],
    feats: torch.Tensor,
    config: FieldConfig,
    progress: Callable[[int], None] | None,
) -> tuple[np.ndarray, tuple[float, ...]]:
    optimiser = Adam(feats, lr=config.learning_rate)
    overlaps: dict[int, np.ndarray] = {}
    generator = torch.Generator().manual_seed(config.seed)
    order_rng = np.random.default_rng(config.seed)
    sample_rng = np.random.default_rng([config.seed, 3])
    order: list[int] = []
    losses: list[float] = []
    for step in range(config.iterations):
        if not order:
            order = [views[k] for k in order_rng.permutation(len(views))]
        v = order.pop()
        optimiser.zero_grad()
        # A view's weights and loss terms are made for its step and dropped after it, so
        # memory holds one view at a time (views may be read from disk, see prepare_views).
        vm = masks[v]
        sample = None
        if 0 < config.pixels_per_step < vm.pixels.shape[0]:
            sample = np.sort(
                sample_rng.choice(vm.pixels.shape[0], config.pixels_per_step, replace=False)
            )
        if v not in overlaps:
            overlaps[v] = mask_overlap(vm)
        terms = _view_terms(vm, sample, overlaps[v])
        rendered = render_features(contributors[v].rows(terms.pixels.numpy()), feats)
        loss = contrastive_loss(rendered, terms, config, generator)
        loss.backward()
        optimiser.step()
        losses.append(float(loss.detach()))
        if progress is not None:
            progress(step + 1)
    return feats.detach().numpy().astype(np.float64), tuple(losses)
