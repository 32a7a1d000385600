"""The knobs of the semantic feature field (DESIGN §2 method defaults), in one frozen dataclass."""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import asdict, dataclass
from typing import Any, Literal

from causalsplat.errors import CausalSplatError

Weighting = Literal["spatial", "average", "random"]
Init = Literal["uplift", "random"]


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
        min_mask_pixels: masks smaller than this take no part (a mask of 1 px still works
            when this is 1).
        min_pixel_alpha: mask pixels where the scene's accumulated opacity is below this
            are left out (nothing is drawn there to supervise; their unit features would
            be noise). 0 keeps every mask pixel.
        min_opacity: Gaussians below this opacity are pruned before rendering.
        seed: every random draw (codes, sampling, view order) derives from it.
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
    min_mask_pixels: int = 4
    min_pixel_alpha: float = 0.5
    min_opacity: float = 1.0 / 255.0
    seed: int = 0

    def __post_init__(self) -> None:
        checks = (
            ("feature_dim", isinstance(self.feature_dim, int) and self.feature_dim >= 2),
            ("weighting", self.weighting in ("spatial", "average", "random")),
            ("w_min", _finite(self.w_min) and 0.0 <= self.w_min <= 1.0),
            ("eps", _finite(self.eps) and self.eps > 0),
            ("init", self.init in ("uplift", "random")),
            ("iterations", isinstance(self.iterations, int) and self.iterations >= 0),
            ("learning_rate", _finite(self.learning_rate) and self.learning_rate > 0),
            (
                "pixels_per_step",
                isinstance(self.pixels_per_step, int) and self.pixels_per_step >= 0,
            ),
            ("margin", _finite(self.margin) and -1.0 <= self.margin < 1.0),
            ("hard_negative", _finite(self.hard_negative) and -1.0 <= self.hard_negative <= 1.0),
            ("negative_weight", _finite(self.negative_weight) and self.negative_weight >= 0),
            (
                "min_mask_pixels",
                isinstance(self.min_mask_pixels, int) and self.min_mask_pixels >= 1,
            ),
            ("min_pixel_alpha", _finite(self.min_pixel_alpha) and 0 <= self.min_pixel_alpha < 1),
            ("min_opacity", _finite(self.min_opacity) and 0.0 <= self.min_opacity < 1.0),
            ("seed", isinstance(self.seed, int) and self.seed >= 0),
        )
        for name, ok in checks:
            if not ok:
                raise FieldConfigError(
                    f"FieldConfig.{name}={getattr(self, name)!r} is out of range"
                )

    def to_json(self) -> dict[str, Any]:
        return asdict(self)

    def digest(self) -> str:
        """Hex content hash of the options (part of the field's cache key)."""
        text = json.dumps(self.to_json(), sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()


def _finite(value: object) -> bool:
    return isinstance(value, int | float) and math.isfinite(value)
