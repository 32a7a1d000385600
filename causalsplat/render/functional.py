"""The public, stateless rasterizer API (EWA splatting of 3D Gaussians, pinhole cameras).

Every render goes through one per-view :class:`~causalsplat.render.types.Contributors`
(sparse pixel x Gaussian blending weights), built by a compiled numba kernel (or, as
``RasterConfig.backend`` says or where numba is missing, by vectorised numpy) and cached by
content; RGB, depth, id maps and features are products of those weights with
per-Gaussian values. :mod:`causalsplat.render._reference` is the float64 per-pixel
reference the tests hold this against. Only :func:`render_features` imports torch.

Conventions: cameras as in :mod:`causalsplat.io.types` (OpenCV, pixel centres at
half-integers); black background; a pixel's composite is ``sum_i w_i f_i`` with
``w_i = alpha_i * prod_{j<i} (1 - alpha_j)`` over the depth-sorted Gaussians it keeps.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from causalsplat.io.types import Camera, GaussianScene
from causalsplat.render._backend import compute_contributors
from causalsplat.render._cache import cache_get, cache_put, contributors_key
from causalsplat.render._sh import view_colors
from causalsplat.render.config import RasterConfig
from causalsplat.render.errors import RenderError
from causalsplat.render.types import Contributors

if TYPE_CHECKING:
    import torch

_DEFAULT = RasterConfig()


def build_contributors(
    scene: GaussianScene, camera: Camera, *, config: RasterConfig = _DEFAULT, cache: bool = True
) -> Contributors:
    """The per-view blending weights of ``scene`` seen by ``camera``.

    Cached by content (scene geometry and opacity, camera, config): a second call with
    equal inputs returns the same object without recomputing. ``cache=False`` bypasses
    the cache both ways, and leaves ``key`` empty: hashing the scene costs more than
    rasterizing a small view (7 MB for 81k Gaussians, at every view of a build).
    """
    if not cache:
        return compute_contributors(scene, camera, config, "")
    key = contributors_key(scene, camera, config)
    hit = cache_get(key)
    if hit is not None:
        return hit
    result = compute_contributors(scene, camera, config, key)
    cache_put(result)
    return result


def render_rgb(
    scene: GaussianScene, camera: Camera, *, config: RasterConfig = _DEFAULT
) -> np.ndarray:
    """(H, W, 3) float32 RGB in [0, 1] on a black background.

    Colours are the scene's SH evaluated at the direction from the camera centre to each
    Gaussian (clamped below at 0, as 3DGS); the composite is clipped to [0, 1].
    """
    contrib = build_contributors(scene, camera, config=config)
    colors = view_colors(scene.sh, scene.means, camera.center)
    return np.clip(contrib.composite(colors), 0.0, 1.0).astype(np.float32)


def render_alpha(
    scene: GaussianScene, camera: Camera, *, config: RasterConfig = _DEFAULT
) -> np.ndarray:
    """(H, W) float32 accumulated opacity (1 - final transmittance) in [0, 1]."""
    return build_contributors(scene, camera, config=config).alpha().astype(np.float32)


def render_depth(
    scene: GaussianScene, camera: Camera, *, config: RasterConfig = _DEFAULT
) -> np.ndarray:
    """(H, W) float32 expected depth ``sum w_i z_i / sum w_i``; 0 where nothing is drawn.

    ``z_i`` is the camera-frame depth of Gaussian ``i``'s centre (scene units).
    """
    contrib = build_contributors(scene, camera, config=config)
    return depth_from_contributors(contrib)


def depth_from_contributors(contrib: Contributors) -> np.ndarray:
    """(H, W) float32 expected depth of a view from its contributors (see render_depth)."""
    num = contrib.composite(contrib.depths.astype(np.float64))
    den = contrib.alpha()
    out = np.zeros_like(num)
    np.divide(num, den, out=out, where=den > 0)
    return out.astype(np.float32)


def render_ids(
    scene: GaussianScene,
    camera: Camera,
    ids: np.ndarray,
    *,
    config: RasterConfig = _DEFAULT,
    min_alpha: float = 0.5,
) -> np.ndarray:
    """(H, W) int64 id map: per pixel the id whose Gaussians carry the most blending weight.

    ``ids`` is (N,) integer, one id per Gaussian (entity or instance id; negative ids mark
    background / unlabelled Gaussians, which still compete and occlude). A pixel is -1
    where its accumulated alpha is below ``min_alpha`` or the winning id is negative.
    Ties go to the smallest id.
    """
    contrib = build_contributors(scene, camera, config=config)
    return ids_from_contributors(contrib, ids, min_alpha=min_alpha)


def ids_from_contributors(
    contrib: Contributors, ids: np.ndarray, *, min_alpha: float = 0.5
) -> np.ndarray:
    """(H, W) int64 id map of a view from its contributors (see :func:`render_ids`)."""
    import scipy.sparse as sp

    ids = np.asarray(ids)
    if ids.shape != (contrib.n_gaussians,) or not np.issubdtype(ids.dtype, np.integer):
        raise RenderError(
            f"ids: expected ({contrib.n_gaussians},) integers, got {ids.shape} {ids.dtype}"
        )
    labels, inverse = np.unique(ids, return_inverse=True)
    out = np.full(contrib.n_pixels, -1, dtype=np.int64)
    if contrib.nnz == 0:
        return out.reshape(contrib.height, contrib.width)
    onehot = sp.csr_matrix(
        (np.ones(ids.shape[0]), (np.arange(ids.shape[0]), inverse.ravel())),
        shape=(ids.shape[0], labels.shape[0]),
    )
    per_label = (contrib.matrix(np.float64) @ onehot).tocsr()
    best = np.asarray(per_label.argmax(axis=1)).ravel()
    winner = labels[best].astype(np.int64)
    alpha = contrib.alpha().ravel()
    ok = (alpha >= min_alpha) & (alpha > 0) & (winner >= 0)
    out[ok] = winner[ok]
    return out.reshape(contrib.height, contrib.width)


def render_features(
    contributors: Contributors,
    features: torch.Tensor,
    *,
    as_image: bool = False,
    pixels: np.ndarray | None = None,
) -> torch.Tensor:
    """Composite per-Gaussian features through cached weights, differentiably.

    ``features`` is (N, C) float32 or float64 (CPU). Returns (H*W, C), or (H, W, C) with
    ``as_image=True``, or with ``pixels`` (flat pixel indices) the (P, C) rows of those
    pixels only, at the cost of their weights alone (nothing is copied where numba
    imports). Autograd runs through a custom function (forward ``W @ f``, backward
    ``W^T @ g``), so gradients reach ``features`` but not the weights.
    """
    from causalsplat.render._autograd import composite_features

    if features.ndim != 2 or features.shape[0] != contributors.n_gaussians:
        raise RenderError(
            f"features: expected shape ({contributors.n_gaussians}, C), got {tuple(features.shape)}"
        )
    if pixels is not None:
        if as_image:
            raise RenderError("render_features: as_image and pixels exclude each other")
        return composite_features(contributors, features, contributors._checked(pixels))
    out = composite_features(contributors, features)
    return out.reshape(contributors.height, contributors.width, -1) if as_image else out
