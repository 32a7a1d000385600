"""Contrastive optimisation of per-Gaussian features through the cached-weight renderer.

One step takes one view (views visited in a seeded random order, each once per epoch) and
``FieldConfig.pixels_per_step`` of its covered pixels, drawn uniformly without replacement
(all of them when 0 or when the view has fewer): render the features ``F = W f`` (P, C) at
those pixels only, normalise each, and for every mask ``m`` with a pixel among them, with
weights ``W_m``:

* prototype ``p_m = Norm(sum_x W_m(x) F̂(x))``;
* positive term ``L_pos(m) = sum_x W_m(x) (1 - F̂(x)·p_m) / sum_x W_m(x)``, which equals
  ``1 - |sum_x W_m(x) F̂(x)| / sum_x W_m(x)`` and is computed that way;
* negatives: covered pixels outside ``m`` and outside every mask nested with ``m``, i.e.
  sharing more than ``FieldConfig.nested_share`` of the smaller one's pixels (a SAM part
  and its whole are not pushed apart; neighbours whose boundaries overlap are). With
  ``S(x) = F̂(x)·p_m``, a negative is kept when ``u < N_pos / N_neg`` (``u ~ U(0, 1)``:
  balances the counts) or ``S(x) > τ`` (hard negatives are always kept); ``L_neg(m)`` is
  the mean of ``max(0, S(x) - margin)`` over the kept ones;
* loss: mean over masks of ``L_pos + λ L_neg``, minimised by Adam on ``f``.

Sampling makes a step cost the same at any image size: on scene0000_00 (320x240, 81k
Gaussians, about 68k covered pixels a view) a step on 4096 of them takes about 8 ms, on all
of them 35 ms, at equal instance quality (docs/benchmarks.md, "Training on sampled
pixels").

This is the CPU fast path. The loss and its gradient with respect to the rendered features
are written out by hand (:func:`contrastive_loss_and_grad`), the render and its transpose
are compiled row kernels (:meth:`~causalsplat.render.types.Contributors.composite_rows`),
and Adam is one compiled pass (numpy without numba): a step runs no autograd bookkeeping,
and a build on the CPU does not import torch (about a second). The torch trainer
(:mod:`causalsplat.field.train_torch`: autograd, ``torch.optim.Adam``, CUDA) walks the same
:func:`step_plan`; the tests hold the two to each other step by step. On the CPU this one
is 2.4-4x faster (docs/benchmarks.md, "Training on torch"). numpy / scipy (numba where
it imports).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass

import numpy as np

from causalsplat.field.adam import Adam
from causalsplat.field.blas import single_threaded_blas
from causalsplat.field.config import FieldConfig
from causalsplat.field.weights import ViewMasks
from causalsplat.render.types import Contributors


@dataclass(frozen=True, slots=True)
class _ViewTerms:
    """Per-view constants of the loss: see the module docstring."""

    pixels: np.ndarray  # (P,) int64 covered pixels
    weights: np.ndarray  # (M, P) float32 dense, W_m on the covered pixels
    weight_sums: np.ndarray  # (M,) float32
    negative: np.ndarray  # (P, M) bool, pixel may serve as a negative of mask m
    n_pos: np.ndarray  # (M,) float32 pixels per mask


def mask_overlap(vm: ViewMasks, share: float = 0.0) -> np.ndarray:
    """(M, M) bool: the masks of ``vm`` nested with each other: sharing more than ``share``
    of the smaller one's pixels (0: any pixel). Each mask is nested with itself."""
    member = (vm.weights > 0).astype(np.float64)
    shared = np.asarray((member @ member.T).toarray())
    size = np.diag(shared).copy()
    nested = shared > share * np.minimum(size[:, None], size[None, :])
    np.fill_diagonal(nested, True)
    return nested


def _view_terms(
    vm: ViewMasks, sample: np.ndarray | None = None, overlap: np.ndarray | None = None
) -> _ViewTerms:
    """The loss terms of ``vm`` on its covered pixels, or on ``vm.pixels[sample]``.

    With a sample, masks that have no pixel in it take no part. ``overlap``: the view's
    :func:`mask_overlap` at the config's ``nested_share`` (the caller keeps it between
    steps); by default masks sharing any pixel.
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
        pixels=pixels.astype(np.int64),
        weights=weights,
        weight_sums=weights.sum(axis=1, dtype=np.float32),
        negative=~blocked,
        n_pos=n_pos.astype(np.float32),
    )


def contrastive_loss(
    f: np.ndarray, terms: _ViewTerms, config: FieldConfig, rng: np.random.Generator
) -> float:
    """The loss of one view (module docstring) from its (P, C) render at ``terms.pixels``."""
    return contrastive_loss_and_grad(f, terms, config, rng)[0]


def contrastive_loss_and_grad(
    f: np.ndarray, terms: _ViewTerms, config: FieldConfig, rng: np.random.Generator
) -> tuple[float, np.ndarray]:
    """The loss of one view and its gradient with respect to ``f`` (P, C), in f's dtype.

    The negatives kept (a random draw and the hard ones) are held fixed, as constants of
    the step; the norms' clamps (1e-8 for a pixel, 1e-12 for a mask's sum) act as in the
    forward pass, so the gradient is that of the function computed.
    """
    dt = f.dtype
    norm = np.linalg.norm(f, axis=1)
    n_clamped = np.maximum(norm, 1e-8).astype(dt)
    unit = f / n_clamped[:, None]
    w = terms.weights.astype(dt, copy=False)
    summed = w @ unit  # (M, C)
    length = np.linalg.norm(summed, axis=1)
    l_clamped = np.maximum(length, 1e-12).astype(dt)
    ws = np.maximum(terms.weight_sums, 1e-12).astype(dt)
    positive = 1.0 - length / ws
    proto = summed / l_clamped[:, None]
    sim = unit @ proto.T  # (P, M)
    n_neg = terms.negative.sum(axis=0)
    ratio = terms.n_pos / np.maximum(n_neg, 1)
    u = rng.random(sim.shape, dtype=np.float32)
    keep = terms.negative & ((u < ratio[None, :]) | (sim > config.hard_negative))
    over = sim - config.margin
    active = keep & (over > 0)
    kept = np.maximum(keep.sum(axis=0), 1).astype(dt)
    negative = np.where(active, over, 0).sum(axis=0) / kept
    m = positive.shape[0]
    loss = float(np.mean(positive + config.negative_weight * negative))
    # Backward, from the loss to the per-pixel features.
    g_sim = active * (dt.type(config.negative_weight / m) / kept)[None, :]  # (P, M)
    g_unit = g_sim.astype(dt) @ proto  # through sim = unit @ proto^T
    g_proto = g_sim.T.astype(dt) @ unit
    # proto = summed / max(length, 1e-12); positive = 1 - length / ws
    radial = np.where(length > 1e-12, (proto * g_proto).sum(axis=1), 0)
    g_summed = (g_proto - radial[:, None] * proto) / l_clamped[:, None]
    g_length = -dt.type(1.0 / m) / ws  # d length / d summed = summed / length
    direction = np.divide(summed, length[:, None], out=np.zeros_like(summed),
                          where=length[:, None] > 0)  # fmt: skip
    g_summed += g_length[:, None] * direction
    g_unit += w.T @ g_summed
    # unit = f / max(norm, 1e-8)
    g_f = g_unit / n_clamped[:, None]
    radial_f = (unit * g_unit).sum(axis=1)
    g_f -= np.where(norm > 1e-8, radial_f, 0)[:, None] * (unit / n_clamped[:, None])
    return loss, g_f.astype(dt, copy=False)


def train_features(
    contributors: Sequence[Contributors],
    masks: Sequence[ViewMasks],
    init: np.ndarray,
    config: FieldConfig,
    *,
    progress: Callable[[int], None] | None = None,
) -> tuple[np.ndarray, tuple[float, ...]]:
    """Optimise ``init`` (N, C) for ``config.iterations`` steps; returns (features, losses).

    numpy's BLAS runs on one thread meanwhile (:mod:`causalsplat.field.blas`): a step's
    products are small. Views without usable masks are skipped. ``progress(k)`` is called
    after each step. Deterministic for a given ``config.seed``.
    """
    views = [i for i, vm in enumerate(masks) if vm.n_masks > 0 and vm.pixels.size > 0]
    feats = np.array(init, dtype=np.float32)
    if not views or config.iterations == 0:
        return feats.astype(np.float64), ()
    with single_threaded_blas():
        losses = _train(contributors, masks, feats, config, progress)
    return feats.astype(np.float64), losses


def step_plan(
    masks: Sequence[ViewMasks], config: FieldConfig
) -> Iterator[tuple[int, np.ndarray | None]]:
    """(view, sorted sample of its covered pixels or ``None`` for all) of every step.

    Views without usable masks are skipped; the others are visited in a seeded random
    order, each once per epoch. Both trainers walk this plan, so they see the same steps.
    """
    views = [i for i, vm in enumerate(masks) if vm.n_masks > 0 and vm.pixels.size > 0]
    if not views:
        return
    order_rng = np.random.default_rng(config.seed)
    sample_rng = np.random.default_rng([config.seed, 3])
    order: list[int] = []
    for _ in range(config.iterations):
        if not order:
            order = [views[k] for k in order_rng.permutation(len(views))]
        v = order.pop()
        n = masks[v].pixels.shape[0]
        sample = None
        if 0 < config.pixels_per_step < n:
            sample = np.sort(sample_rng.choice(n, config.pixels_per_step, replace=False))
        yield v, sample


def _train(
    contributors: Sequence[Contributors],
    masks: Sequence[ViewMasks],
    feats: np.ndarray,
    config: FieldConfig,
    progress: Callable[[int], None] | None,
) -> tuple[float, ...]:
    """Train ``feats`` in place; returns the losses."""
    optimiser = Adam(feats, lr=config.learning_rate)
    gradient = np.zeros_like(feats)  # one buffer for every step's gradient
    overlaps: dict[int, np.ndarray] = {}
    negatives_rng = np.random.default_rng([config.seed, 4])
    losses: list[float] = []
    for step, (v, sample) in enumerate(step_plan(masks, config)):
        # A view's weights and loss terms are made for its step and dropped after it, so
        # memory holds one view at a time (views may be read from disk, see prepare_views).
        vm = masks[v]
        if v not in overlaps:
            overlaps[v] = mask_overlap(vm, config.nested_share)
        terms = _view_terms(vm, sample, overlaps[v])
        contrib = contributors[v]
        rendered = contrib.composite_rows(terms.pixels, feats)
        loss, grad = contrastive_loss_and_grad(rendered, terms, config, negatives_rng)
        optimiser.step(contrib.transposed_rows(terms.pixels, grad, out=gradient))
        losses.append(loss)
        if progress is not None:
            progress(step + 1)
    return tuple(losses)
