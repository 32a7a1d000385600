"""Compiled EWA projection of every Gaussian into one camera (the numba path's step 1).

The same maths, culling and pixel extents as
:func:`causalsplat.render._project.project_gaussians`, one Gaussian per loop iteration, in
float64, for a range of Gaussians (the caller runs ranges on several threads); the results
land in arrays the caller allocates. The depth sort stays with the caller (one ``argsort``
of the visible Gaussians).
"""

from __future__ import annotations

import math

import numpy as np

from causalsplat.render._jit import jit

#: Columns of the per-Gaussian parameter rows (``params``) the tile kernels read: centre
#: (px), conic, opacity, the exponent below which alpha < alpha_min (less REJECT_MARGIN),
#: and the chord of the ellipse ``alpha >= alpha_min`` on a pixel row ``dy`` below the
#: centre: centred at ``MX + SHIFT * dy``, half-width ``sqrt(max(REACH - dy², 0) * SQUEEZE)``.
MX, MY, CA, CB, CC, OPACITY, PMIN, SHIFT, REACH, SQUEEZE, DECAY = range(11)
N_PARAMS = 11  # DECAY: exp(-CA), the ratio of successive exp steps along a row
#: ``status`` values: culled (0), visible, covariance overflows float64.
VISIBLE, OVERFLOW = 1, 2
#: Safety margin (in units of the exponent) of the cheap rejection test ``power < PMIN``:
#: a pair it rejects has ``opacity * exp(power) < alpha_min`` whatever the rounding.
REJECT_MARGIN = 1e-9


@jit()
def _expit(x: float) -> float:
    """Overflow-free logistic sigmoid."""
    if x >= 0.0:
        return 1.0 / (1.0 + math.exp(-x))
    e = math.exp(x)
    return e / (1.0 + e)


@jit()
def _pixel_range(center: float, half: float, size: int) -> tuple[int, int]:
    """Half-open range of pixels whose centres (i + 0.5) lie in ``center ± half``, clipped."""
    lo = math.floor(min(max(center - half - 0.5, -1.0), size + 1.0))
    hi = math.floor(min(max(center + half - 0.5, -1.0), size + 1.0)) + 1
    return min(max(int(lo), 0), size), min(max(int(hi), 0), size)


@jit()
def _rotate_row(a0: float, a1: float, a2: float, quat: np.ndarray) -> tuple[float, float, float]:
    """Row ``(a0, a1, a2) @ R(q)``, ``R(q)`` as :func:`causalsplat.io._geometry.quat_to_rotmat`
    (wxyz, normalised here)."""
    w, x, y, z = (
        np.float64(quat[0]),
        np.float64(quat[1]),
        np.float64(quat[2]),
        np.float64(quat[3]),
    )
    norm = math.sqrt(w * w + x * x + y * y + z * z)
    w, x, y, z = w / norm, x / norm, y / norm, z / norm
    r0 = (1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y))
    r1 = (2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x))
    r2 = (2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y))
    return (
        a0 * r0[0] + a1 * r1[0] + a2 * r2[0],
        a0 * r0[1] + a1 * r1[1] + a2 * r2[1],
        a0 * r0[2] + a1 * r1[2] + a2 * r2[2],
    )


@jit()
def _dot3(
    a: tuple[float, float, float], v: tuple[float, float, float], b: tuple[float, float, float]
) -> float:
    """``sum_k a_k v_k b_k``."""
    return a[0] * v[0] * b[0] + a[1] * v[1] * b[1] + a[2] * v[2] * b[2]


@jit()
def _camera_covariance(
    quat: np.ndarray, log_scale: np.ndarray, rot_cw: np.ndarray
) -> tuple[float, float, float, float, float, float]:
    """Upper triangle (xx, xy, xz, yy, yz, zz) of the camera-frame covariance
    ``M diag(exp(2 s)) Mᵀ`` with ``M = rot_cw R(q)``."""
    m0 = _rotate_row(rot_cw[0, 0], rot_cw[0, 1], rot_cw[0, 2], quat)
    m1 = _rotate_row(rot_cw[1, 0], rot_cw[1, 1], rot_cw[1, 2], quat)
    m2 = _rotate_row(rot_cw[2, 0], rot_cw[2, 1], rot_cw[2, 2], quat)
    var = (
        math.exp(2.0 * np.float64(log_scale[0])),
        math.exp(2.0 * np.float64(log_scale[1])),
        math.exp(2.0 * np.float64(log_scale[2])),
    )
    return (
        _dot3(m0, var, m0),
        _dot3(m0, var, m1),
        _dot3(m0, var, m2),
        _dot3(m1, var, m1),
        _dot3(m1, var, m2),
        _dot3(m2, var, m2),
    )


@jit()
def project_kernel(
    means: np.ndarray,
    quats: np.ndarray,
    log_scales: np.ndarray,
    logits: np.ndarray,
    rot_cw: np.ndarray,
    center: np.ndarray,
    cam: np.ndarray,
    near: float,
    far: float,
    alpha_min: float,
    status: np.ndarray,
    depth: np.ndarray,
    params: np.ndarray,
    bbox: np.ndarray,
    first: int,
    last: int,
) -> None:
    """Fill ``status`` (0 culled, 1 visible, 2 covariance overflow), ``depth``, ``params``
    and ``bbox`` of Gaussians ``first .. last - 1``; ``cam`` is (fx, fy, cx, cy, W, H,
    margin, low_pass)."""
    fx, fy, cx, cy = cam[0], cam[1], cam[2], cam[3]
    width, height = int(cam[4]), int(cam[5])
    margin, low_pass = cam[6], cam[7]
    tan_x, tan_y = 0.5 * width / fx, 0.5 * height / fy
    ux_lo, ux_hi = -cx / fx - margin * tan_x, (width - cx) / fx + margin * tan_x
    uy_lo, uy_hi = -cy / fy - margin * tan_y, (height - cy) / fy + margin * tan_y
    for i in range(first, last):
        status[i] = 0
        opacity = _expit(np.float64(logits[i]))
        if not opacity >= alpha_min:
            continue
        px = np.float64(means[i, 0]) - center[0]
        py = np.float64(means[i, 1]) - center[1]
        pz = np.float64(means[i, 2]) - center[2]
        x = rot_cw[0, 0] * px + rot_cw[0, 1] * py + rot_cw[0, 2] * pz
        y = rot_cw[1, 0] * px + rot_cw[1, 1] * py + rot_cw[1, 2] * pz
        z = rot_cw[2, 0] * px + rot_cw[2, 1] * py + rot_cw[2, 2] * pz
        if not (z >= near and z <= far):
            continue
        sxx, sxy, sxz, syy, syz, szz = _camera_covariance(quats[i], log_scales[i], rot_cw)
        if not (
            math.isfinite(sxx)
            and math.isfinite(sxy)
            and math.isfinite(sxz)
            and math.isfinite(syy)
            and math.isfinite(syz)
            and math.isfinite(szz)
        ):
            status[i] = OVERFLOW
            continue
        ux = min(max(x / z, ux_lo), ux_hi)
        uy = min(max(y / z, uy_lo), uy_hi)
        # J = [[fx/z, 0, -fx ux/z], [0, fy/z, -fy uy/z]]; Σ2D = J Σ Jᵀ + low_pass I.
        j00, j02, j11, j12 = fx / z, -fx * ux / z, fy / z, -fy * uy / z
        a = j00 * (j00 * sxx + j02 * sxz) + j02 * (j00 * sxz + j02 * szz) + low_pass
        b = j11 * (j00 * sxy + j02 * syz) + j12 * (j00 * sxz + j02 * szz)
        c = j11 * (j11 * syy + j12 * syz) + j12 * (j11 * syz + j12 * szz) + low_pass
        det = a * c - b * b
        if not (det > 0.0 and math.isfinite(det)):
            continue
        mx = fx * x / z + cx
        my = fy * y / z + cy
        qmax = 2.0 * math.log(opacity / alpha_min)
        x0, x1 = _pixel_range(mx, math.sqrt(qmax * a), width)
        y0, y1 = _pixel_range(my, math.sqrt(qmax * c), height)
        if not (x1 > x0 and y1 > y0):
            continue
        status[i] = VISIBLE
        depth[i] = z
        params[i, MX] = mx
        params[i, MY] = my
        params[i, CA] = c / det
        params[i, CB] = -b / det
        params[i, CC] = a / det
        params[i, OPACITY] = opacity
        params[i, PMIN] = math.log(alpha_min / opacity) - REJECT_MARGIN
        # q(dx, dy) = conic form; min over dx at dx = (b / c) dy is dy² / c, and
        # q <= qmax there for |dx - (b / c) dy| <= sqrt((c qmax - dy²) det) / c.
        params[i, SHIFT] = b / c
        params[i, REACH] = c * qmax
        params[i, SQUEEZE] = det / (c * c)
        params[i, DECAY] = math.exp(-c / det)
        bbox[i, 0], bbox[i, 1], bbox[i, 2], bbox[i, 3] = x0, x1, y0, y1
