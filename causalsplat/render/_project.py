"""Vectorised float64 EWA projection of all Gaussians of a scene into one camera (fast path).

Everything here is float64; the camera centre is subtracted before rotating, so scenes
far from the origin lose no precision beyond what their float32 storage already lost.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import expit

from causalsplat.io.types import Camera, GaussianScene
from causalsplat.render.config import RasterConfig
from causalsplat.render.errors import RenderError


@dataclass(frozen=True, slots=True)
class Projected:
    """The Gaussians that can reach a pixel of the view, sorted front to back.

    Attributes:
        index: (M,) int64 indices into the scene, nearest first (stable for equal depths).
        mean2d: (M, 2) float64 projected centres (u, v) in pixels.
        conic: (M, 3) float64 ``(a, b, c)`` of the inverse 2D covariance; the Gaussian at
            offset ``(dx, dy)`` px is ``exp(-0.5 * (a dx² + 2 b dx dy + c dy²))``.
        opacity: (M,) float64 opacity (sigmoid of the logit).
        depth: (M,) float64 camera-frame z of the centre, scene units.
        bbox: (M, 4) int64 ``x0, x1, y0, y1``: the pixels (half-open ranges, clipped to the
            image) whose centres can receive alpha >= ``alpha_min`` from the Gaussian.
    """

    index: np.ndarray
    mean2d: np.ndarray
    conic: np.ndarray
    opacity: np.ndarray
    depth: np.ndarray
    bbox: np.ndarray


def camera_covariances(scene: GaussianScene, camera: Camera, index: np.ndarray) -> np.ndarray:
    """(M, 3, 3) float64 covariances of Gaussians ``index`` in the camera frame."""
    rot = camera.R_cam_world @ scene.rotation_matrices[index]  # (M, 3, 3)
    with np.errstate(over="ignore", invalid="ignore"):
        var = np.exp(2.0 * scene.log_scales[index].astype(np.float64))  # (M, 3)
        cov = np.einsum("nij,nj,nkj->nik", rot, var, rot)
    bad = ~np.all(np.isfinite(cov), axis=(1, 2))
    if bad.any():
        raise covariance_overflow_error(scene, index[bad])
    return cov


def covariance_overflow_error(scene: GaussianScene, bad: np.ndarray) -> RenderError:
    """The error for Gaussians ``bad`` (ascending scene indices) whose covariance overflows."""
    first = int(bad[0])
    return RenderError(
        f"covariance of {int(bad.shape[0])} Gaussian(s) overflows float64 "
        f"(first: Gaussian {first}, log_scales {scene.log_scales[first].tolist()})"
    )


def _jacobians(camera: Camera, pc: np.ndarray, margin: float) -> np.ndarray:
    """(M, 2, 3) Jacobians of the pinhole projection at camera points ``pc``."""
    z = pc[:, 2]
    tan_x = 0.5 * camera.width / camera.fx
    tan_y = 0.5 * camera.height / camera.fy
    ux = np.clip(
        pc[:, 0] / z,
        -camera.cx / camera.fx - margin * tan_x,
        (camera.width - camera.cx) / camera.fx + margin * tan_x,
    )
    uy = np.clip(
        pc[:, 1] / z,
        -camera.cy / camera.fy - margin * tan_y,
        (camera.height - camera.cy) / camera.fy + margin * tan_y,
    )
    jac = np.zeros((pc.shape[0], 2, 3))
    jac[:, 0, 0] = camera.fx / z
    jac[:, 0, 2] = -camera.fx * ux / z
    jac[:, 1, 1] = camera.fy / z
    jac[:, 1, 2] = -camera.fy * uy / z
    return jac


def _pixel_range(center: np.ndarray, half: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray]:
    """Half-open integer ranges of pixels whose centres (i + 0.5) lie in center ± half."""
    lo = np.floor(np.clip(center - half - 0.5, -1.0, size + 1.0))
    hi = np.floor(np.clip(center + half - 0.5, -1.0, size + 1.0)) + 1
    return np.clip(lo, 0, size).astype(np.int64), np.clip(hi, 0, size).astype(np.int64)


def project_gaussians(scene: GaussianScene, camera: Camera, config: RasterConfig) -> Projected:
    """EWA-project ``scene`` into ``camera``: cull, 2D covariances, conics, extents, depth order."""
    opacity = expit(scene.opacity_logits.astype(np.float64))
    pc_all = camera.world_to_camera(scene.means)
    z_all = pc_all[:, 2]
    keep = (opacity >= config.alpha_min) & (z_all >= config.near) & (z_all <= config.far)
    index = np.flatnonzero(keep)
    pc = pc_all[index]
    z = pc[:, 2]
    cov_c = camera_covariances(scene, camera, index)
    jac = _jacobians(camera, pc, config.jacobian_margin)
    cov2d = np.einsum("nij,njk,nlk->nil", jac, cov_c, jac)
    a = cov2d[:, 0, 0] + config.low_pass
    b = cov2d[:, 0, 1]
    c = cov2d[:, 1, 1] + config.low_pass
    det = a * c - b * b
    # A singular 2D covariance can only arise with low_pass == 0 and a degenerate Gaussian.
    ok = (det > 0) & np.isfinite(det)
    mean2d = np.stack(
        [camera.fx * pc[:, 0] / z + camera.cx, camera.fy * pc[:, 1] / z + camera.cy], 1
    )
    # alpha >= alpha_min needs q = d^T Σ^-1 d <= 2 ln(opacity / alpha_min); the ellipse
    # {q <= qmax} has axis-aligned half-extents sqrt(qmax Σxx), sqrt(qmax Σyy).
    qmax = 2.0 * np.log(opacity[index] / config.alpha_min)
    x0, x1 = _pixel_range(mean2d[:, 0], np.sqrt(qmax * a), camera.width)
    y0, y1 = _pixel_range(mean2d[:, 1], np.sqrt(qmax * c), camera.height)
    ok &= (x1 > x0) & (y1 > y0)
    sel = np.flatnonzero(ok)
    order = sel[np.argsort(z[sel], kind="stable")]
    det_o = det[order]
    conic = np.stack([c[order] / det_o, -b[order] / det_o, a[order] / det_o], axis=1)
    return Projected(
        index=index[order],
        mean2d=mean2d[order],
        conic=conic,
        opacity=opacity[index][order],
        depth=z[order],
        bbox=np.stack([x0[order], x1[order], y0[order], y1[order]], axis=1),
    )
