"""Baseline for the render benchmark: a dense per-tile alpha composite in torch.

This is what a differentiable rasterizer without cached weights does on the CPU: every
forward pass recomputes, for each screen tile, alpha for all (pixel, Gaussian) pairs of
the Gaussians binned to the tile (depth-sorted), the transmittance by ``cumprod``, the
3DGS stopping rules as masks, and composites the features; backward runs through torch
autograd. Projection and tile binning are done once (the geometry is frozen), so the
comparison isolates the compositing that the cached weights replace.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from causalsplat.io.types import Camera, GaussianScene
from causalsplat.render._contributors import _bin_to_tiles
from causalsplat.render._project import project_gaussians
from causalsplat.render.config import RasterConfig


@dataclass(frozen=True, slots=True)
class _Tile:
    pixels: torch.Tensor  # (P,) int64 flat pixel indices
    px: torch.Tensor  # (P,) float pixel-centre x
    py: torch.Tensor  # (P,) float pixel-centre y
    gaussians: torch.Tensor  # (K,) int64 scene indices, front to back
    ranks: torch.Tensor  # (K,) int64 rows of the projected arrays


class DenseTileCompositor:
    """Differentiable dense composite of per-Gaussian features for one view."""

    def __init__(self, scene: GaussianScene, camera: Camera, config: RasterConfig) -> None:
        if config.max_contributors is not None:
            raise ValueError("the dense baseline composites without a per-pixel cap")
        proj = project_gaussians(scene, camera, config)
        self.config = config
        self.n_pixels = camera.width * camera.height
        self.mean2d = torch.from_numpy(proj.mean2d.astype(np.float32))
        self.conic = torch.from_numpy(proj.conic.astype(np.float32))
        self.opacity = torch.from_numpy(proj.opacity.astype(np.float32))
        tile, width, height = config.tile_size, camera.width, camera.height
        tiles_x = -(-width // tile)
        tile_ids, ranks = _bin_to_tiles(proj, tiles_x, tile)
        bounds = np.flatnonzero(np.diff(tile_ids)) + 1
        starts = np.concatenate([[0], bounds]) if tile_ids.size else np.zeros(0, np.int64)
        ends = np.concatenate([bounds, [tile_ids.size]]) if tile_ids.size else starts
        self.tiles: list[_Tile] = []
        for s, e in zip(starts.tolist(), ends.tolist()):
            t = int(tile_ids[s])
            xs = np.arange((t % tiles_x) * tile, min((t % tiles_x) * tile + tile, width))
            ys = np.arange((t // tiles_x) * tile, min((t // tiles_x) * tile + tile, height))
            px, py = np.tile(xs, ys.shape[0]), np.repeat(ys, xs.shape[0])
            r = ranks[s:e]
            self.tiles.append(
                _Tile(
                    pixels=torch.from_numpy(py * width + px),
                    px=torch.from_numpy(px + 0.5).float(),
                    py=torch.from_numpy(py + 0.5).float(),
                    gaussians=torch.from_numpy(proj.index[r]),
                    ranks=torch.from_numpy(r),
                )
            )

        self.all_pixels = (
            torch.cat([t.pixels for t in self.tiles]) if self.tiles else torch.zeros(0).long()
        )

    def _weights(self, tile: _Tile) -> torch.Tensor:
        cfg = self.config
        m, q, o = self.mean2d[tile.ranks], self.conic[tile.ranks], self.opacity[tile.ranks]
        dx = tile.px[:, None] - m[None, :, 0]
        dy = tile.py[:, None] - m[None, :, 1]
        power = -0.5 * (q[:, 0] * dx * dx + q[:, 2] * dy * dy) - q[:, 1] * dx * dy
        alpha = torch.clamp(o * torch.exp(torch.clamp(power, max=0.0)), max=cfg.alpha_max)
        alpha = torch.where(alpha < cfg.alpha_min, torch.zeros_like(alpha), alpha)
        t_after = torch.cumprod(1.0 - alpha, dim=1)
        t_before = t_after / (1.0 - alpha)
        return alpha * t_before * (t_after >= cfg.transmittance_min)

    def __call__(self, features: torch.Tensor) -> torch.Tensor:
        """(H*W, C) composite of (N, C) features; differentiable in ``features``."""
        out = features.new_zeros((self.n_pixels, features.shape[1]))
        if not self.tiles:
            return out
        parts = [self._weights(t).to(features.dtype) @ features[t.gaussians] for t in self.tiles]
        return out.index_add(0, self.all_pixels, torch.cat(parts))
