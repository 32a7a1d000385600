"""Real spherical harmonics up to degree 3 (the 3DGS basis and sign convention), numpy."""

from __future__ import annotations

import math

import numpy as np

from causalsplat.io.types import SH_C0

SH_C1 = 0.4886025119029199
SH_C2 = (
    1.0925484305920792,
    -1.0925484305920792,
    0.31539156525252005,
    -1.0925484305920792,
    0.5462742152960396,
)
SH_C3 = (
    -0.5900435899266435,
    2.890611442640554,
    -0.4570457994644658,
    0.3731763325901154,
    -0.4570457994644658,
    1.445305721320277,
    -0.5900435899266435,
)


def sh_basis(dirs: np.ndarray, degree: int) -> np.ndarray:
    """(N, (degree+1)**2) float64 basis values at unit directions ``dirs`` (N, 3)."""
    x, y, z = dirs[:, 0], dirs[:, 1], dirs[:, 2]
    cols = [np.full_like(x, SH_C0)]
    if degree >= 1:
        cols += [-SH_C1 * y, SH_C1 * z, -SH_C1 * x]
    if degree >= 2:
        xx, yy, zz, xy, yz, xz = x * x, y * y, z * z, x * y, y * z, x * z
        cols += [
            SH_C2[0] * xy,
            SH_C2[1] * yz,
            SH_C2[2] * (2.0 * zz - xx - yy),
            SH_C2[3] * xz,
            SH_C2[4] * (xx - yy),
        ]
    if degree >= 3:
        cols += [
            SH_C3[0] * y * (3 * xx - yy),
            SH_C3[1] * xy * z,
            SH_C3[2] * y * (4 * zz - xx - yy),
            SH_C3[3] * z * (2 * zz - 3 * xx - 3 * yy),
            SH_C3[4] * x * (4 * zz - xx - yy),
            SH_C3[5] * z * (xx - yy),
            SH_C3[6] * x * (xx - 3 * yy),
        ]
    return np.stack(cols, axis=1)


def view_colors(sh: np.ndarray, means: np.ndarray, center: np.ndarray) -> np.ndarray:
    """(N, 3) float64 RGB seen from ``center``: ``max(0.5 + sum_k basis_k(d) sh_k, 0)``.

    ``sh`` is (N, K, 3); ``d`` is the unit direction from the camera centre to each mean
    (computed in float64; a mean at the centre uses d = +z). As in 3DGS, colours are
    clamped below at 0 but not above.
    """
    degree = math.isqrt(sh.shape[1]) - 1
    d = np.asarray(means, dtype=np.float64) - np.asarray(center, dtype=np.float64)
    norm = np.linalg.norm(d, axis=1, keepdims=True)
    d = np.where(norm > 0, d / np.where(norm > 0, norm, 1.0), np.array([0.0, 0.0, 1.0]))
    basis = sh_basis(d, degree)
    rgb = np.einsum("nk,nkc->nc", basis, sh.astype(np.float64)) + 0.5
    return np.maximum(rgb, 0.0)
