"""Float64 reference rasterizer: direct, per pixel, per Gaussian. Small scenes only.

Written to be read, not to be fast, and independently of the fast path (its own
quaternion rotation, projection and compositing). For every pixel centre it walks all
Gaussians in depth order and applies the 3DGS rules literally:

    alpha = min(alpha_max, opacity * exp(-0.5 d^T Σ2D^-1 d));  skip if alpha < alpha_min
    if T * (1 - alpha) < transmittance_min: stop (this Gaussian is not drawn)
    weight = alpha * T;  T = T * (1 - alpha);  stop after max_contributors drawn

with Σ2D = J W Σ W^T J^T + low_pass I (EWA), J the pinhole Jacobian at the mean with x/z
and y/z clamped to the widened field of view, and Gaussians with camera depth outside
[near, far] culled. The result is the dense (H*W, N) weight matrix; renders are products.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import expit

from causalsplat.io.types import Camera, GaussianScene
from causalsplat.render._sh import view_colors
from causalsplat.render.config import RasterConfig

_DEFAULT = RasterConfig()


def _quat_mul(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    pw, px, py, pz = p
    qw, qx, qy, qz = q
    return np.array(
        [
            pw * qw - px * qx - py * qy - pz * qz,
            pw * qx + px * qw + py * qz - pz * qy,
            pw * qy - px * qz + py * qw + pz * qx,
            pw * qz + px * qy - py * qx + pz * qw,
        ]
    )


def _rotation(q: np.ndarray) -> np.ndarray:
    """3x3 rotation whose columns are the basis vectors rotated as q v q*."""
    q = q / np.linalg.norm(q)
    conj = q * np.array([1.0, -1.0, -1.0, -1.0])
    cols = [_quat_mul(_quat_mul(q, np.concatenate([[0.0], e])), conj)[1:] for e in np.eye(3)]
    return np.stack(cols, axis=1)


def _project_one(
    scene: GaussianScene, i: int, camera: Camera, config: RasterConfig
) -> tuple[np.ndarray, np.ndarray, float, float] | None:
    """(mean2d, inverse 2D covariance, opacity, depth) of Gaussian i, or None if culled."""
    mean = scene.means[i].astype(np.float64)
    p = camera.R_cam_world @ (mean - camera.center)
    x, y, z = p
    if not config.near <= z <= config.far:
        return None
    rot = camera.R_cam_world @ _rotation(scene.quats[i].astype(np.float64))
    s = np.diag(np.exp(scene.log_scales[i].astype(np.float64)))
    cov = rot @ s @ s @ rot.T
    tan_x, tan_y = 0.5 * camera.width / camera.fx, 0.5 * camera.height / camera.fy
    m = config.jacobian_margin
    ux = min(
        max(x / z, -camera.cx / camera.fx - m * tan_x),
        (camera.width - camera.cx) / camera.fx + m * tan_x,
    )
    uy = min(
        max(y / z, -camera.cy / camera.fy - m * tan_y),
        (camera.height - camera.cy) / camera.fy + m * tan_y,
    )
    jac = np.array(
        [[camera.fx / z, 0.0, -camera.fx * ux / z], [0.0, camera.fy / z, -camera.fy * uy / z]]
    )
    cov2d = jac @ cov @ jac.T + config.low_pass * np.eye(2)
    if np.linalg.det(cov2d) <= 0:
        return None
    mean2d = np.array([camera.fx * x / z + camera.cx, camera.fy * y / z + camera.cy])
    opacity = float(expit(float(scene.opacity_logits[i])))
    return mean2d, np.linalg.inv(cov2d), opacity, float(z)


def reference_weights(
    scene: GaussianScene, camera: Camera, config: RasterConfig = _DEFAULT
) -> np.ndarray:
    """Dense (H*W, N) float64 blending weights; row ``row * W + col``."""
    projected = [(i, _project_one(scene, i, camera, config)) for i in range(scene.n)]
    visible = [(i, pr) for i, pr in projected if pr is not None]
    visible.sort(key=lambda item: (item[1][3], item[0]))  # by depth, then index
    weights = np.zeros((camera.height * camera.width, scene.n))
    for row in range(camera.height):
        for col in range(camera.width):
            pixel = np.array([col + 0.5, row + 0.5])
            t, drawn = 1.0, 0
            for i, (mean2d, conic, opacity, _z) in visible:
                d = pixel - mean2d
                alpha = min(config.alpha_max, opacity * math.exp(-0.5 * float(d @ conic @ d)))
                if alpha < config.alpha_min:
                    continue
                if t * (1.0 - alpha) < config.transmittance_min:
                    break
                weights[row * camera.width + col, i] = alpha * t
                t *= 1.0 - alpha
                drawn += 1
                if config.max_contributors is not None and drawn >= config.max_contributors:
                    break
    return weights


def reference_depths(scene: GaussianScene, camera: Camera) -> np.ndarray:
    """(N,) float64 camera-frame depth of each Gaussian centre."""
    return camera.world_to_camera(scene.means)[:, 2]


def reference_rgb(scene: GaussianScene, camera: Camera, weights: np.ndarray) -> np.ndarray:
    """(H, W, 3) float64 RGB in [0, 1] from reference weights."""
    colors = view_colors(scene.sh, scene.means, camera.center)
    return np.clip(weights @ colors, 0.0, 1.0).reshape(camera.height, camera.width, 3)


def reference_depth(scene: GaussianScene, camera: Camera, weights: np.ndarray) -> np.ndarray:
    """(H, W) float64 expected depth, 0 where the accumulated alpha is 0."""
    num = weights @ reference_depths(scene, camera)
    den = weights.sum(axis=1)
    out = np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0)
    return out.reshape(camera.height, camera.width)


def reference_ids(
    weights: np.ndarray, ids: np.ndarray, shape: tuple[int, int], min_alpha: float = 0.5
) -> np.ndarray:
    """(H, W) int64 id map: the id with the largest summed weight per pixel, else -1."""
    labels = np.unique(ids)
    per_label = np.stack([weights[:, ids == lab].sum(axis=1) for lab in labels], axis=1)
    winner = labels[np.argmax(per_label, axis=1)]
    alpha = weights.sum(axis=1)
    out = np.where((alpha >= min_alpha) & (alpha > 0) & (winner >= 0), winner, -1)
    return out.astype(np.int64).reshape(shape)
