"""A SAM-like noise model that turns exact GT instance masks into realistic mask proposals.

Real class-agnostic segmenters (SAM and its relatives) make a small set of characteristic
mistakes; :func:`perturb_masks` reproduces each of them with a probability (or an amplitude)
that is the :class:`NoiseConfig` rate multiplied by one ``strength`` knob (clipped to
probability 1). ``strength = 0`` returns the input unchanged; ``strength = 1`` gives the
default rates below. Effects, in the order they are applied to one view:

1. **Dropped masks** (``p_drop`` = 0.05): each mask is missed entirely.
2. **Under-segmentation** (``p_merge`` = 0.08): each pair of adjacent masks (their pixels
   within ``adjacency_px`` = 2 px) is merged into one mask, labelled as its larger part; a
   mask takes part in at most one merge.
3. **Over-segmentation** (``p_split`` = 0.10): a mask of at least ``min_split_area_px`` = 40
   pixels is cut into 2 parts (3 with probability ``p_three_parts`` = 0.3) by straight cuts
   perpendicular to a random direction, at random quantiles in [0.25, 0.75] of its pixels.
   Every part keeps the label.
4. **Boundary jitter** (``p_jitter`` = 0.6, amplitude ``jitter_px`` = 1.5 px): the mask's
   boundary band is randomly eroded or dilated: the mask becomes ``d < a * f`` where ``d``
   is its signed distance (pixels, negative inside, ±0.5 at the boundary), ``a`` the
   amplitude and ``f`` a smooth random field in [-1, 1] (white noise blurred with
   ``jitter_smooth_px`` = 2). Only pixels within ``a`` of the boundary change.
5. **Spurious fragments** (``fragment_rate`` = 0.4 per view, Poisson): small elliptical
   blobs, radii ``fragment_radius`` = 2-6 % of the shorter image side, anywhere in the
   image, labelled ``fragment_label`` = ``"object"``.

Masks left with fewer than ``min_area_px`` = 4 pixels are removed. Scores mimic SAM's
predicted IoU: 1.0 for an untouched mask, multiplied by 0.9 after jitter, 0.8 after a split
and 0.75 after a merge; fragments score 0.3-0.6. Output masks carry no ``ids``. Everything
is drawn from the given seeded :class:`numpy.random.Generator`, in a fixed order, so equal
seeds give equal masks.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

import numpy as np

from causalsplat.errors import CausalSplatError
from causalsplat.masks.types import MaskSet

#: The largest noise strength: the rarest default effect (``p_drop`` 0.05) is certain at
#: 20, so any more only scales the jitter past every mask.
MAX_STRENGTH = 20.0


class InvalidNoiseError(CausalSplatError, ValueError):
    """A noise strength or :class:`NoiseConfig` value is out of range."""


@dataclass(frozen=True, slots=True)
class NoiseConfig:
    """Per-effect rates of the SAM-like noise model at ``strength = 1`` (module docstring)."""

    p_drop: float = 0.05
    p_merge: float = 0.08
    adjacency_px: int = 2
    p_split: float = 0.10
    p_three_parts: float = 0.3
    min_split_area_px: int = 40
    p_jitter: float = 0.6
    jitter_px: float = 1.5
    jitter_smooth_px: float = 2.0
    fragment_rate: float = 0.4
    fragment_radius: tuple[float, float] = field(default=(0.02, 0.06))
    fragment_label: str = "object"
    min_area_px: int = 4

    def __post_init__(self) -> None:
        for name in ("p_drop", "p_merge", "p_split", "p_three_parts", "p_jitter"):
            value = getattr(self, name)
            if not 0.0 <= value <= 1.0:
                raise InvalidNoiseError(f"NoiseConfig.{name}={value} is not in [0, 1]")
        for name in ("jitter_px", "jitter_smooth_px", "fragment_rate"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise InvalidNoiseError(f"NoiseConfig.{name}={value} must be finite and >= 0")
        lo, hi = self.fragment_radius
        if not 0 < lo <= hi <= 0.5:
            raise InvalidNoiseError(f"NoiseConfig.fragment_radius={self.fragment_radius}")


@dataclass(slots=True)
class _Mask:
    pixels: np.ndarray  # (H, W) bool
    label: str | None
    score: float


def perturb_masks(
    maskset: MaskSet,
    strength: float,
    rng: np.random.Generator,
    config: NoiseConfig | None = None,
) -> MaskSet:
    """Apply the SAM-like noise model (module docstring) to one view's masks.

    Args:
        maskset: the exact masks (typically from :func:`masks_from_id_render`).
        strength: multiplies every rate and the jitter amplitude; 0 returns ``maskset``.
        rng: the random generator (seed it for reproducible output).
        config: per-effect rates (default :class:`NoiseConfig`).

    Returns a new :class:`MaskSet` with scores (and labels when the input had labels).
    """
    try:
        s = float(strength)
    except (TypeError, ValueError):
        s = math.nan
    if not 0 <= s <= MAX_STRENGTH:
        raise InvalidNoiseError(
            f"noise strength must be in [0, {MAX_STRENGTH:g}], got {strength!r}"
        )
    if s == 0:
        return maskset
    cfg = config or NoiseConfig()
    labels = maskset.labels
    scores = maskset.scores
    items = [
        _Mask(
            pixels=maskset.masks[i].copy(),
            label=None if labels is None else labels[i],
            score=1.0 if scores is None else float(scores[i]),
        )
        for i in range(maskset.n)
    ]
    items = [m for m in items if rng.random() >= min(1.0, cfg.p_drop * s)]
    items = _merge_adjacent(items, min(1.0, cfg.p_merge * s), cfg.adjacency_px, rng)
    items = _split_some(items, min(1.0, cfg.p_split * s), cfg, rng)
    for item in items:
        if rng.random() < min(1.0, cfg.p_jitter * s):
            item.pixels = _jitter(item.pixels, cfg.jitter_px * s, cfg.jitter_smooth_px, rng)
            item.score *= 0.9
    shape = (maskset.height, maskset.width)
    for _ in range(int(rng.poisson(cfg.fragment_rate * s))):
        label = None if labels is None else cfg.fragment_label
        items.append(_fragment(shape, cfg.fragment_radius, label, rng))
    items = [m for m in items if int(m.pixels.sum()) >= cfg.min_area_px]
    masks = np.stack([m.pixels for m in items]) if items else np.zeros((0, *shape), dtype=bool)
    return MaskSet(
        view=maskset.view,
        masks=masks,
        labels=None if labels is None else tuple(str(m.label) for m in items),
        scores=np.array([m.score for m in items], dtype=np.float32),
    )


def _merge_adjacent(
    items: list[_Mask], p: float, adjacency_px: int, rng: np.random.Generator
) -> list[_Mask]:
    if len(items) < 2 or p <= 0:
        return items
    from scipy import ndimage  # here: a build imports this package, never the noise

    structure = ndimage.generate_binary_structure(2, 1)
    flat = np.stack([m.pixels.reshape(-1) for m in items]).astype(np.float32)
    grown = np.stack(
        [
            ndimage.binary_dilation(m.pixels, structure, iterations=max(1, adjacency_px))
            .reshape(-1)
            .astype(np.float32)
            for m in items
        ]
    )
    touching = (grown @ flat.T) > 0
    merged_into: dict[int, int] = {}
    used: set[int] = set()
    n = len(items)
    for i in range(n):
        for j in range(i + 1, n):
            draw = rng.random()
            if not touching[i, j] or i in used or j in used or draw >= p:
                continue
            used.update((i, j))
            merged_into[j] = i
    out: list[_Mask] = []
    for i, item in enumerate(items):
        if i in merged_into:
            continue
        partners = [j for j, k in merged_into.items() if k == i]
        if partners:
            j = partners[0]
            other = items[j]
            big = item if item.pixels.sum() >= other.pixels.sum() else other
            item = _Mask(
                pixels=item.pixels | other.pixels,
                label=big.label,
                score=min(item.score, other.score) * 0.75,
            )
        out.append(item)
    return out


def _split_some(
    items: list[_Mask], p: float, cfg: NoiseConfig, rng: np.random.Generator
) -> list[_Mask]:
    out: list[_Mask] = []
    for item in items:
        draw = rng.random()
        rows, cols = np.nonzero(item.pixels)
        if draw >= p or rows.size < cfg.min_split_area_px:
            out.append(item)
            continue
        theta = rng.uniform(0.0, math.pi)
        parts = 3 if rng.random() < cfg.p_three_parts else 2
        cuts = np.sort(rng.uniform(0.25, 0.75, parts - 1))
        proj = cols * math.cos(theta) + rows * math.sin(theta)
        edges = [-np.inf, *np.quantile(proj, cuts), np.inf]
        for lo, hi in itertools.pairwise(edges):
            sel = (proj >= lo) & (proj < hi)
            if not sel.any():
                continue
            piece = np.zeros_like(item.pixels)
            piece[rows[sel], cols[sel]] = True
            out.append(_Mask(pixels=piece, label=item.label, score=item.score * 0.8))
    return out


def _jitter(
    mask: np.ndarray, amplitude: float, smooth_px: float, rng: np.random.Generator
) -> np.ndarray:
    """Move the boundary of ``mask`` by a smooth random field of ``amplitude`` pixels."""
    rows, cols = np.nonzero(mask)
    if rows.size == 0 or amplitude <= 0:
        return mask
    pad = math.ceil(amplitude) + 2
    h, w = mask.shape
    r0, r1 = max(0, rows.min() - pad), min(h, rows.max() + pad + 1)
    c0, c1 = max(0, cols.min() - pad), min(w, cols.max() + pad + 1)
    crop = mask[r0:r1, c0:c1]
    from scipy import ndimage

    inside = ndimage.distance_transform_edt(crop)
    outside = ndimage.distance_transform_edt(~crop)
    signed = np.where(crop, 0.5 - inside, outside - 0.5)
    noise = ndimage.gaussian_filter(rng.standard_normal(crop.shape), smooth_px, mode="wrap")
    peak = float(np.abs(noise).max())
    if peak > 0:
        noise /= peak
    out = mask.copy()
    out[r0:r1, c0:c1] = signed < amplitude * noise
    return out


def _fragment(
    shape: tuple[int, int],
    radius_frac: tuple[float, float],
    label: str | None,
    rng: np.random.Generator,
) -> _Mask:
    h, w = shape
    side = min(h, w)
    cy, cx = rng.uniform(0, h), rng.uniform(0, w)
    ry, rx = rng.uniform(radius_frac[0], radius_frac[1], 2) * side
    angle = rng.uniform(0.0, math.pi)
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float64) + 0.5
    dy, dx = yy - cy, xx - cx
    u = dx * math.cos(angle) + dy * math.sin(angle)
    v = -dx * math.sin(angle) + dy * math.cos(angle)
    pixels = (u / max(rx, 0.5)) ** 2 + (v / max(ry, 0.5)) ** 2 <= 1.0
    return _Mask(pixels=pixels, label=label, score=float(rng.uniform(0.3, 0.6)))
