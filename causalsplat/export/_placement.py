"""Greedy placement of text labels that never overlap, and a round scale-bar length.

Pure geometry in pixels (``y`` down), no drawing: :mod:`causalsplat.export.figure` measures
the texts and draws the result.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

#: ``(x0, y0, x1, y1)`` in pixels, ``x0 <= x1``, ``y0 <= y1``.
Box = tuple[float, float, float, float]

#: Directions tried on each ring around an anchor, as angles in degrees (right first).
_ANGLES = np.deg2rad(np.arange(0, 360, 15))


def _candidates(anchor: tuple[float, float], size: tuple[float, float], gap: float,
                reach: float) -> np.ndarray:  # fmt: skip
    """``(C, 4)`` boxes for one label, nearest first: beside the anchor (right, left,
    above, below, then the corners), then centred on rings of growing radius."""
    x, y = anchor
    w, h = size
    near = [
        (x + gap, y - h / 2), (x - gap - w, y - h / 2), (x - w / 2, y - gap - h),
        (x - w / 2, y + gap), (x + gap, y - gap - h), (x - gap - w, y - gap - h),
        (x + gap, y + gap), (x - gap - w, y + gap),
    ]  # fmt: skip
    step = max(h, 1.0)
    radii = np.arange(step, max(reach, step) + step, step)
    r = radii[:, None]
    cx = (x + r * np.cos(_ANGLES)).ravel()
    cy = (y + r * np.sin(_ANGLES)).ravel()
    corners = np.concatenate([np.asarray(near), np.stack([cx - w / 2, cy - h / 2], axis=1)])
    return np.concatenate([corners, corners + np.asarray([w, h])], axis=1)


def place_labels(
    anchors: Sequence[tuple[float, float]],
    sizes: Sequence[tuple[float, float]],
    bounds: Box,
    *,
    obstacles: Sequence[Box] = (),
    gap: float = 4.0,
    padding: float = 1.0,
) -> list[Box | None]:
    """A box of ``sizes[i]`` for each label, as near ``anchors[i]`` as space allows.

    Labels are placed in order; each takes the first candidate (:func:`_candidates`) that
    lies inside ``bounds`` and keeps ``padding`` pixels from every box placed before it
    and from every obstacle (the dots, other drawings). A label that finds no place gets
    ``None`` (the caller lists it elsewhere). Boxes returned never overlap.

    >>> place_labels([(50, 50), (52, 50)], [(30, 10), (30, 10)], (0, 0, 200, 200))
    [(54.0, 45.0, 84.0, 55.0), (18.0, 45.0, 48.0, 55.0)]
    """
    placed = np.asarray(obstacles, dtype=np.float64).reshape(-1, 4)
    bx0, by0, bx1, by1 = bounds
    reach = math.hypot(bx1 - bx0, by1 - by0)
    out: list[Box | None] = []
    for anchor, size in zip(anchors, sizes, strict=True):
        cand = _candidates(anchor, size, gap, reach)
        ok = (cand[:, 0] >= bx0) & (cand[:, 1] >= by0) & (cand[:, 2] <= bx1) & (cand[:, 3] <= by1)
        if placed.size:
            hit = (
                (cand[:, None, 0] < placed[None, :, 2] + padding)
                & (placed[None, :, 0] < cand[:, None, 2] + padding)
                & (cand[:, None, 1] < placed[None, :, 3] + padding)
                & (placed[None, :, 1] < cand[:, None, 3] + padding)
            )
            ok &= ~hit.any(axis=1)
        free = np.flatnonzero(ok)
        if free.size == 0:
            out.append(None)
            continue
        box = cand[free[0]]
        placed = np.concatenate([placed, box[None, :]])
        out.append((float(box[0]), float(box[1]), float(box[2]), float(box[3])))
    return out


def nearest_point(box: Box, point: tuple[float, float]) -> tuple[float, float]:
    """The point of ``box`` (edge or inside) nearest ``point``: where a leader line ends.

    >>> nearest_point((10, 10, 20, 20), (0, 15))
    (10, 15)
    """
    x, y = point
    return (min(max(x, box[0]), box[2]), min(max(y, box[1]), box[3]))


def scale_bar_length(span: float) -> float:
    """The longest 1, 2 or 5 times a power of ten that is at most ``span`` (> 0).

    >>> [scale_bar_length(s) for s in (0.8, 3.7, 12.0, 0.049)]
    [0.5, 2.0, 10.0, 0.02]
    """
    if not span > 0 or not math.isfinite(span):
        raise ValueError(f"a scale bar needs a finite span > 0, got {span}")
    power = 10.0 ** math.floor(math.log10(span))
    for mantissa in (5.0, 2.0, 1.0):
        if mantissa * power <= span * (1 + 1e-12):
            return float(f"{mantissa * power:.12g}")
    return power  # pragma: no cover - mantissa 1 always fits
