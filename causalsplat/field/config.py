"""The knobs of the semantic feature field (DESIGN §2 method defaults), in one frozen dataclass."""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass
from typing import Any, Literal

from causalsplat._checks import Allowed, Interval, check_fields
from causalsplat.errors import CausalSplatError

Weighting = Literal["spatial", "average", "random"]
Init = Literal["uplift", "random"]
Device = Literal["auto", "cpu", "cuda"]
Trainer = Literal["auto", "numpy", "torch"]


#: The most contrastive steps a build takes (300 by default; about 2 h at 7 ms a step).
MAX_ITERATIONS = 1_000_000
#: The widest per-Gaussian feature (16 by default): memory grows with it, per Gaussian.
MAX_FEATURE_DIM = 1024


class FieldConfigError(CausalSplatError, ValueError):
    """A :class:`FieldConfig` value is out of range; the message names the field."""


@dataclass(frozen=True, slots=True)
class FieldConfig:
    """Options of the feature field: mask weighting, initialisation, contrastive training.

    Attributes:
        feature_dim: C, channels of the per-Gaussian feature.
        weighting: how pixels of a mask are weighted in its feature: ``spatial`` (the
            method: ``W = w_min + (1 - w_min)(1 - d / (d_max + eps))`` with ``d`` the
            distance to the mask's geometric centre), ``average`` (``W = 1``) or
            ``random`` (``W ~ U(w_min, 1)`` per pixel; ablation).
        w_min: ω_min, the weight of a mask's farthest pixel (0.4).
        eps: px, keeps ``d / (d_max + eps)`` finite for one-pixel masks (``d_max = 0``).
        init: ``uplift`` (training-free: every mask gets a random unit code and each
            Gaussian the weight-averaged sum of the codes of the masks it is drawn into,
            over all views) or ``random`` (i.i.d. normal features).
        iterations: contrastive steps (one view each; 0 = the initialisation only).
        learning_rate: Adam's step size on the per-Gaussian features.
        pixels_per_step: covered pixels of the view that one step's loss samples
            (uniformly, without replacement); 0 takes them all. Rendering, loss and
            gradient cost in proportion. 4096 kept the mean best IoU of every scene of
            docs/benchmarks.md ("Training on sampled pixels"); 2048 lost 0.02 on one.
        margin: m, negatives are pushed to cosine similarity at most ``margin`` (0.03).
        hard_negative: τ, a negative pixel with similarity above this is always kept (0.5).
        negative_weight: λ, weight of the negative term against the positive one.
        nested_share: two masks of a view count as one inside the other (a SAM part and
            its whole), and neither is a negative of the other, when they share more than
            this share of the smaller one's pixels. 0: any shared pixel, which also spares
            neighbouring masks whose boundaries overlap by a pixel or two, as real and
            noisy masks do; on the masks of scene0000_00 prepared at 1000x750 that kept
            neighbouring objects together (docs/benchmarks.md, "Nested masks").
        min_mask_pixels: masks smaller than this take no part (a mask of 1 px still works
            when this is 1).
        min_pixel_alpha: mask pixels where the scene's accumulated opacity is below this
            are left out (nothing is drawn there to supervise; their unit features would
            be noise). 0 keeps every mask pixel.
        min_opacity: Gaussians below this opacity are pruned before rendering.
        seed: every random draw (codes, sampling, view order) derives from it.
        device: where the torch trainer runs: ``cuda``, ``cpu``, or ``auto`` (CUDA when this
            machine has an NVIDIA GPU that torch sees, else the CPU).
        trainer: ``torch`` (autograd and ``torch.optim.Adam`` on ``device``), ``numpy``
            (the hand-derived gradient and a compiled Adam, CPU only, held to the torch one
            by the tests) or ``auto``: torch on a CUDA device for scenes of at least
            600k Gaussians, numpy otherwise, whichever was the faster where measured
            (:mod:`causalsplat.field.device`; docs/benchmarks.md, "Training on torch").
    """

    feature_dim: int = 16
    weighting: Weighting = "spatial"
    w_min: float = 0.4
    eps: float = 1e-6
    init: Init = "uplift"
    iterations: int = 300
    learning_rate: float = 0.02
    pixels_per_step: int = 4096
    margin: float = 0.03
    hard_negative: float = 0.5
    negative_weight: float = 1.0
    nested_share: float = 0.5
    min_mask_pixels: int = 4
    min_pixel_alpha: float = 0.5
    min_opacity: float = 1.0 / 255.0
    seed: int = 0
    device: Device = "auto"
    trainer: Trainer = "auto"

    def __post_init__(self) -> None:
        check_fields("FieldConfig", asdict(self), _ALLOWED, FieldConfigError)

    def to_json(self) -> dict[str, Any]:
        return asdict(self)

    def digest(self) -> str:
        """Hex content hash of the options (part of the field's cache key)."""
        text = json.dumps(self.to_json(), sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()


_ALLOWED: dict[str, Allowed] = {
    "feature_dim": Interval(2, MAX_FEATURE_DIM, integer=True),
    "weighting": ("spatial", "average", "random"),
    "w_min": Interval(0, 1),
    "eps": Interval(0, low_open=True),
    "init": ("uplift", "random"),
    "iterations": Interval(0, MAX_ITERATIONS, integer=True),
    "learning_rate": Interval(0, low_open=True),
    "pixels_per_step": Interval(0, integer=True),
    "margin": Interval(-1, 1, high_open=True),
    "hard_negative": Interval(-1, 1),
    "negative_weight": Interval(0),
    "nested_share": Interval(0, 1),
    "min_mask_pixels": Interval(1, integer=True),
    "min_pixel_alpha": Interval(0, 1, high_open=True),
    "min_opacity": Interval(0, 1, high_open=True),
    "seed": Interval(0, integer=True),
    "device": ("auto", "cpu", "cuda"),
    "trainer": ("auto", "numpy", "torch"),
}
