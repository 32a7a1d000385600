"""Naming an entity's colour from its Gaussians: the nearest basic colour term in CIELAB.

The palette holds the eleven basic colour terms of Berlin and Kay plus ``beige`` and
``teal`` (names typical referring expressions use), as sRGB in [0, 1]; the synthetic
rooms are painted from the same palette. A median colour darker or lighter than every
palette entry still gets the nearest one; shading (faces at 75-100 % brightness) moves
mostly L*, so lightness counts half as much as the two chroma axes.
"""

from __future__ import annotations

import numpy as np

#: Colour name -> sRGB in [0, 1].
PALETTE: dict[str, tuple[float, float, float]] = {
    "red": (0.80, 0.17, 0.15),
    "orange": (0.92, 0.52, 0.15),
    "yellow": (0.93, 0.83, 0.22),
    "green": (0.25, 0.62, 0.28),
    "teal": (0.15, 0.55, 0.56),
    "blue": (0.20, 0.35, 0.80),
    "purple": (0.52, 0.30, 0.68),
    "pink": (0.92, 0.55, 0.68),
    "white": (0.92, 0.92, 0.90),
    "gray": (0.55, 0.55, 0.57),
    "black": (0.12, 0.12, 0.13),
    "brown": (0.48, 0.31, 0.18),
    "beige": (0.85, 0.77, 0.60),
}


def srgb_to_lab(rgb: np.ndarray) -> np.ndarray:
    """(..., 3) sRGB in [0, 1] to CIELAB (D65), float64."""
    c = np.clip(np.asarray(rgb, dtype=np.float64), 0.0, 1.0)
    lin = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    m = np.array(
        [[0.4124564, 0.3575761, 0.1804375],
         [0.2126729, 0.7151522, 0.0721750],
         [0.0193339, 0.1191920, 0.9503041]]
    )  # fmt: skip
    xyz = lin @ m.T / np.array([0.95047, 1.0, 1.08883])
    eps, kappa = 216 / 24389, 24389 / 27
    f = np.where(xyz > eps, np.cbrt(xyz), (kappa * xyz + 16) / 116)
    return np.stack(
        [116 * f[..., 1] - 16, 500 * (f[..., 0] - f[..., 1]), 200 * (f[..., 1] - f[..., 2])],
        axis=-1,
    )


_NAMES = tuple(PALETTE)
_LAB = srgb_to_lab(np.array([PALETTE[n] for n in _NAMES]))
_WEIGHT = np.array([0.5, 1.0, 1.0])


def color_name(colors: np.ndarray) -> str | None:
    """The palette name nearest to the median of (K, 3) sRGB colours; ``None`` when K = 0."""
    colors = np.asarray(colors, dtype=np.float64).reshape(-1, 3)
    if colors.shape[0] == 0:
        return None
    lab = srgb_to_lab(np.median(colors, axis=0))
    d = (((_LAB - lab) * _WEIGHT) ** 2).sum(axis=1)
    return _NAMES[int(np.argmin(d))]
