"""Numpy path: per-view blending weights built with vectorised numpy, one tile at a time.

The readable reference of the compiled kernel (:mod:`causalsplat.render._kernel`, the
default) and its fallback where numba is not installed (``RasterConfig.backend``).

The Gaussians are projected once (float64), binned to the screen tiles their pixel extent
touches, and each tile composites its depth-sorted list in chunks: alpha for all
(pixel, Gaussian) pairs of the chunk, the transmittance as a cumulative sum of
``log(1 - alpha)``, and the 3DGS stopping rules (``alpha_min``, ``transmittance_min``,
``max_contributors``) as masks. No Python loop runs over pixels or Gaussians.
"""

from __future__ import annotations

import numpy as np

from causalsplat.io.types import Camera, GaussianScene
from causalsplat.render._project import Projected, project_gaussians
from causalsplat.render.config import RasterConfig
from causalsplat.render.types import Contributors


def _bin_to_tiles(proj: Projected, tiles_x: int, tile: int) -> tuple[np.ndarray, np.ndarray]:
    """(tile id, depth rank) of every Gaussian-tile overlap, grouped by tile, front to back."""
    tx0, tx1 = proj.bbox[:, 0] // tile, (proj.bbox[:, 1] - 1) // tile + 1
    ty0, ty1 = proj.bbox[:, 2] // tile, (proj.bbox[:, 3] - 1) // tile + 1
    nx = tx1 - tx0
    counts = nx * (ty1 - ty0)
    rank = np.repeat(np.arange(counts.shape[0]), counts)
    starts = np.cumsum(counts) - counts
    local = np.arange(rank.shape[0]) - np.repeat(starts, counts)
    tile_id = (ty0[rank] + local // nx[rank]) * tiles_x + tx0[rank] + local % nx[rank]
    order = np.argsort(tile_id, kind="stable")  # stable: keeps depth order inside a tile
    return tile_id[order], rank[order]


def _composite_tile(
    px: np.ndarray, py: np.ndarray, ranks: np.ndarray, proj: Projected, config: RasterConfig
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Weights of one tile: (local pixel, depth rank, weight) of every kept pair."""
    n_pix = px.shape[0]
    log_t = np.zeros(n_pix)  # log transmittance in front of the current chunk
    count = np.zeros(n_pix, dtype=np.int64)
    cap = config.max_contributors
    log_tmin = np.log(config.transmittance_min) if config.transmittance_min > 0 else -np.inf
    out_p, out_g, out_w = [], [], []
    for start in range(0, ranks.shape[0], config.chunk):
        g = ranks[start : start + config.chunk]
        dx = (px + 0.5)[:, None] - proj.mean2d[g, 0][None, :]
        dy = (py + 0.5)[:, None] - proj.mean2d[g, 1][None, :]
        ca, cb, cc = proj.conic[g, 0], proj.conic[g, 1], proj.conic[g, 2]
        power = -0.5 * (ca * dx * dx + cc * dy * dy) - cb * dx * dy
        alpha = np.minimum(config.alpha_max, proj.opacity[g] * np.exp(np.minimum(power, 0.0)))
        alpha[alpha < config.alpha_min] = 0.0
        log1m = np.log1p(-alpha)
        log_after = np.cumsum(log1m, axis=1) + log_t[:, None]
        keep = (alpha > 0) & (log_after >= log_tmin)
        if cap is not None:
            keep &= (np.cumsum(keep, axis=1) + count[:, None]) <= cap
        rows, cols = np.nonzero(keep)
        out_p.append(rows)
        out_g.append(g[cols])
        out_w.append(alpha[rows, cols] * np.exp(log_after[rows, cols] - log1m[rows, cols]))
        log_t = log_after[:, -1]
        count += keep.sum(axis=1)
        done = log_t < log_tmin
        if cap is not None:
            done |= count >= cap
        if done.all():
            break
    if not out_p:
        empty = np.zeros(0, dtype=np.int64)
        return empty, empty, np.zeros(0)
    return np.concatenate(out_p), np.concatenate(out_g), np.concatenate(out_w)


def compute_contributors_numpy(
    scene: GaussianScene, camera: Camera, config: RasterConfig, key: str
) -> Contributors:
    """Build the :class:`Contributors` of ``scene`` seen from ``camera`` (no caching here)."""
    proj = project_gaussians(scene, camera, config)
    width, height, tile = camera.width, camera.height, config.tile_size
    tiles_x = -(-width // tile)
    tile_ids, ranks = _bin_to_tiles(proj, tiles_x, tile)
    bounds = np.flatnonzero(np.diff(tile_ids)) + 1
    starts = np.concatenate([[0], bounds]) if tile_ids.size else np.zeros(0, dtype=np.int64)
    ends = np.concatenate([bounds, [tile_ids.size]]) if tile_ids.size else starts
    pix_all, gau_all, w_all = [], [], []
    for s, e in zip(starts.tolist(), ends.tolist()):
        t = int(tile_ids[s])
        x0, y0 = (t % tiles_x) * tile, (t // tiles_x) * tile
        xs = np.arange(x0, min(x0 + tile, width))
        ys = np.arange(y0, min(y0 + tile, height))
        px = np.tile(xs, ys.shape[0])
        py = np.repeat(ys, xs.shape[0])
        rows, g, w = _composite_tile(px, py, ranks[s:e], proj, config)
        pix_all.append(py[rows] * width + px[rows])
        gau_all.append(g)
        w_all.append(w)
    return _to_csr(scene, camera, proj, key, pix_all, gau_all, w_all)


def _to_csr(
    scene: GaussianScene,
    camera: Camera,
    proj: Projected,
    key: str,
    pix_all: list[np.ndarray],
    gau_all: list[np.ndarray],
    w_all: list[np.ndarray],
) -> Contributors:
    n_pix = camera.width * camera.height
    pix = np.concatenate(pix_all) if pix_all else np.zeros(0, dtype=np.int64)
    rank = np.concatenate(gau_all) if gau_all else np.zeros(0, dtype=np.int64)
    weights = np.concatenate(w_all) if w_all else np.zeros(0)
    order = np.argsort(pix, kind="stable")  # stable: rows stay front to back
    indptr = np.zeros(n_pix + 1, dtype=np.int64)
    np.cumsum(np.bincount(pix, minlength=n_pix), out=indptr[1:])
    depths = np.zeros(scene.n, dtype=np.float32)
    depths[proj.index] = proj.depth
    return Contributors(
        width=camera.width,
        height=camera.height,
        n_gaussians=scene.n,
        indptr=indptr,
        indices=proj.index[rank[order]].astype(np.int32),
        weights=weights[order].astype(np.float32),
        depths=depths,
        key=key,
    )
