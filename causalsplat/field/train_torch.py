"""The contrastive training of :mod:`causalsplat.field.train` on torch: autograd, Adam, any device.

The same steps as the numpy trainer: the same views in the same seeded order, the same
pixels drawn per step, the same random draw deciding which negatives are kept (made by
numpy's generator from the same seed, so both trainers see the same numbers); only the
arithmetic runs in torch. A step:

1. the sampled pixels' rows of the view's blending weights ``W`` become a torch sparse CSR
   tensor on the device (:meth:`~causalsplat.render.types.Contributors.rows`);
2. ``F = W f`` (P, C) by ``torch.sparse.mm``, the loss of the module docstring of
   :mod:`causalsplat.field.train` written in torch operations (:func:`contrastive_loss`);
3. ``loss.backward()`` (autograd) and one ``torch.optim.Adam`` step on ``f``.

Imports torch (``pip install 'causalsplat[field]'``); a CUDA device is used when
:attr:`FieldConfig.device` asks for one or ``auto`` finds one.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import torch

from causalsplat.field.config import FieldConfig
from causalsplat.field.train import _view_terms, mask_overlap, step_plan
from causalsplat.field.weights import ViewMasks
from causalsplat.render.types import Contributors


def torch_device(config: FieldConfig) -> torch.device:
    """The device ``config.device`` names (``auto``: CUDA when torch sees one)."""
    if config.device == "cuda" or (config.device == "auto" and torch.cuda.is_available()):
        return torch.device("cuda")
    return torch.device("cpu")


def contrastive_loss(
    f: torch.Tensor,
    weights: torch.Tensor,
    negative: torch.Tensor,
    n_pos: torch.Tensor,
    draw: torch.Tensor,
    config: FieldConfig,
) -> torch.Tensor:
    """The loss of one view from its (P, C) render ``f`` (a scalar tensor, differentiable).

    ``weights`` (M, P) are the masks' pixel weights, ``negative`` (P, M) which pixels may
    be negatives of which mask, ``n_pos`` (M,) pixels per mask, ``draw`` (P, M) uniform
    numbers deciding the kept negatives. The clamps (1e-8 for a pixel's norm, 1e-12 for a
    mask's sum) are those of the numpy trainer; the kept negatives are constants of the step.
    """
    unit = f / torch.linalg.vector_norm(f, dim=1).clamp_min(1e-8)[:, None]
    summed = weights @ unit  # (M, C)
    length = torch.linalg.vector_norm(summed, dim=1)
    positive = 1.0 - length / weights.sum(dim=1).clamp_min(1e-12)
    proto = summed / length.clamp_min(1e-12)[:, None]
    sim = unit @ proto.T  # (P, M)
    with torch.no_grad():
        ratio = n_pos / negative.sum(dim=0).clamp_min(1)
        keep = negative & ((draw < ratio[None, :]) | (sim > config.hard_negative))
        kept = keep.sum(dim=0).clamp_min(1).to(f.dtype)
    hinge = torch.relu(sim - config.margin) * keep
    return torch.mean(positive + config.negative_weight * hinge.sum(dim=0) / kept)


def _render_rows(c: Contributors, pixels: np.ndarray, feats: torch.Tensor) -> torch.Tensor:
    """(P, C) render ``W f`` at ``pixels``, differentiable in ``feats`` (N, C).

    The sampled rows of the view's blending weights become a sparse COO tensor (P, N) on
    ``feats``' device (rows in order, so already coalesced); ``torch.sparse.mm`` renders,
    and autograd gives ``W^T g`` for the gradient.
    """
    r = c.rows(pixels)
    row = np.repeat(np.arange(pixels.shape[0], dtype=np.int64), np.diff(r.indptr))
    index = torch.from_numpy(np.stack([row, np.asarray(r.indices, dtype=np.int64)]))
    w = torch.sparse_coo_tensor(
        index,
        torch.from_numpy(np.asarray(r.weights, dtype=np.float32)),
        size=(pixels.shape[0], c.n_gaussians),
        is_coalesced=True,
        check_invariants=False,
    ).to(feats.device)
    return torch.sparse.mm(w, feats)


def train_features_torch(
    contributors: Sequence[Contributors],
    masks: Sequence[ViewMasks],
    init: np.ndarray,
    config: FieldConfig,
    *,
    progress: Callable[[int], None] | None = None,
) -> tuple[np.ndarray, tuple[float, ...]]:
    """Optimise ``init`` (N, C) for ``config.iterations`` steps; returns (features, losses).

    The torch counterpart of :func:`causalsplat.field.train.train_features`, with the same
    arguments and results; the features live on :func:`torch_device` meanwhile.
    """
    device = torch_device(config)
    feats = torch.tensor(np.asarray(init, dtype=np.float32), device=device, requires_grad=True)
    optimiser = torch.optim.Adam([feats], lr=config.learning_rate)
    negatives_rng = np.random.default_rng([config.seed, 4])
    overlaps: dict[int, np.ndarray] = {}
    losses: list[float] = []
    pending: list[torch.Tensor] = []

    def to(a: np.ndarray, dtype: Any = None) -> torch.Tensor:
        return torch.from_numpy(np.ascontiguousarray(a)).to(device, dtype=dtype)

    for step, (v, sample) in enumerate(step_plan(masks, config)):
        vm = masks[v]
        if v not in overlaps:
            overlaps[v] = mask_overlap(vm, config.nested_share)
        terms = _view_terms(vm, sample, overlaps[v])
        draw = negatives_rng.random((terms.pixels.shape[0], terms.weights.shape[0]),
                                    dtype=np.float32)  # fmt: skip
        rendered = _render_rows(contributors[v], terms.pixels, feats)
        loss = contrastive_loss(
            rendered, to(terms.weights), to(terms.negative), to(terms.n_pos), to(draw), config
        )
        optimiser.zero_grad(set_to_none=True)
        loss.backward()
        optimiser.step()
        pending.append(loss.detach())
        if progress is not None:
            progress(step + 1)
    if pending:  # one device-to-host copy for all the losses
        losses = torch.stack(pending).cpu().tolist()
    return feats.detach().cpu().numpy().astype(np.float64), tuple(losses)
