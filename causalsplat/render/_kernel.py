"""Compiled path: per-view blending weights built by numba kernels, parallel over tiles.

The default backend (``RasterConfig.backend``). Same rules, same output and same order as
the numpy path (:mod:`causalsplat.render._contributors`, the readable reference), fused
into loops so that no (pixel, Gaussian) array is ever materialised:

1. :func:`~causalsplat.render._kernel_project.project_kernel` (ranges of Gaussians):
   cull, EWA 2D covariance, conic, pixel extent; then one stable ``argsort`` by depth.
2. :func:`~causalsplat.render._kernel_tiles.tile_counts` / ``tile_fill``: each tile's
   front-to-back list of Gaussians, and a bound on its number of weights.
3. :func:`~causalsplat.render._kernel_tiles.composite_tiles` (ranges of tiles). When the
   bounds fit ``SCRATCH_BYTES`` it runs once, each tile writing its weights to its own
   region of a scratch buffer, and ``gather_rows`` moves them into CSR order. Otherwise (or
   if a region overflowed, which the bound rules out) it runs twice: count each pixel's
   contributors, which gives the row pointers, then write every weight in place.

Rows come out in pixel order and front to back within a row: nothing is sorted after
the depth sort. Arithmetic is float64 and weights are stored as float32, as the numpy
path does; the pixels and Gaussians kept are the same and weights agree to float32
rounding.

Threads: the kernels are compiled ``nogil`` and run on ranges of Gaussians, tiles and
pixel rows handed to :attr:`RasterConfig.threads` Python threads (default: the cores this
process may use, at most numba's ``NUMBA_NUM_THREADS``). Not numba's ``prange``: its
OpenMP layer spin-waits at the end of each parallel loop, which on a busy host costs a
scheduler time slice per loop (12 ms for an empty loop with 2 threads on the loaded 2-core
benchmark host, more than the whole view takes); its other layers are either not always
installed (TBB) or not thread-safe (workqueue), and choosing one is process-wide. A pixel
is computed by one thread, so the output does not depend on the thread count.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from itertools import pairwise

import numba
import numpy as np

from causalsplat.io.types import Camera, GaussianScene
from causalsplat.render._kernel_project import N_PARAMS, OVERFLOW, VISIBLE, project_kernel
from causalsplat.render._kernel_tiles import (
    COUNT,
    FINAL,
    SCRATCH,
    composite_tiles,
    gather_rows,
    make_room,
    tile_counts,
    tile_fill,
)
from causalsplat.render._project import covariance_overflow_error
from causalsplat.render.config import RasterConfig
from causalsplat.render.types import Contributors

#: Largest scratch buffer (bytes; 8 per bounded weight) of the one-pass mode; beyond it the
#: kernel composites twice (count, then write) and needs no scratch.
SCRATCH_BYTES = 1 << 30
#: The kernel's screen tiles, px (performance only; ``RasterConfig.tile_size`` is the numpy
#: path's): wide and short, since a tile is composited row by row, each Gaussian over its
#: chord of the row. On ScanNet views 128 x 8 took 25 ms where 16 x 16 took 33.
TILE_WIDTH, TILE_HEIGHT = 128, 8
#: Ranges of tiles per thread: tiles differ in cost, small ranges balance the threads.
_TILE_RANGES_PER_THREAD = 8


def available_cores() -> int:
    """Cores this process may run on (its CPU affinity where the OS has one)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def thread_count(config: RasterConfig) -> int:
    """Threads the kernel uses for ``config``: its ``threads``, or the available cores;
    at most numba's ``NUMBA_NUM_THREADS``."""
    wanted = config.threads if config.threads is not None else available_cores()
    return max(1, min(wanted, numba.config.NUMBA_NUM_THREADS))


class _Ranges:
    """Runs ``task(first, last)`` over ranges that cover ``0 .. count - 1``, on ``threads``
    Python threads (inline for one); the kernels release the GIL."""

    def __init__(self, threads: int) -> None:
        self.threads = threads
        self.pool = ThreadPoolExecutor(threads) if threads > 1 else None

    def run(self, task: Callable[[int, int], None], count: int, per_thread: int = 1) -> None:
        if self.pool is None or count < 2:
            task(0, count)
            return
        bounds = np.linspace(0, count, min(count, self.threads * per_thread) + 1).astype(int)
        futures = [self.pool.submit(task, int(a), int(b)) for a, b in pairwise(bounds)]
        for future in futures:
            future.result()

    def close(self) -> None:
        if self.pool is not None:
            self.pool.shutdown()


def _project(
    scene: GaussianScene, camera: Camera, config: RasterConfig, ranges: _Ranges
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(order, depth, params, bbox): the visible Gaussians front to back, and per Gaussian
    its depth, parameter row and pixel extent (see ``project_kernel``)."""
    n = scene.n
    status = np.empty(n, dtype=np.int8)  # the kernel sets every entry; the rest only
    depth = np.empty(n)  # where status is VISIBLE, and is read nowhere else
    params = np.empty((n, N_PARAMS))
    bbox = np.empty((n, 4), dtype=np.int64)
    intrinsics = [camera.fx, camera.fy, camera.cx, camera.cy, camera.width, camera.height]
    cam = np.array([*intrinsics, config.jacobian_margin, config.low_pass], dtype=np.float64)
    rot_cw = np.ascontiguousarray(camera.R_cam_world, dtype=np.float64)
    center = np.ascontiguousarray(camera.center, dtype=np.float64)
    gaussians = (scene.means, scene.quats, scene.log_scales, scene.opacity_logits)
    view = (rot_cw, center, cam, config.near, config.far, config.alpha_min)
    out = (status, depth, params, bbox)
    ranges.run(lambda a, b: project_kernel(*gaussians, *view, *out, a, b), n)
    bad = np.flatnonzero(status == OVERFLOW)
    if bad.size:
        raise covariance_overflow_error(scene, bad)
    visible = np.flatnonzero(status == VISIBLE)
    return visible[np.argsort(depth[visible], kind="stable")], depth, params, bbox


class _Tiles:
    """The tile lists of a view: ``starts`` (cumulative counts), ``lists`` (scene indices,
    front to back), ``bound`` (cumulative bounds on their weights), ``longest``."""

    def __init__(self, order: np.ndarray, bbox: np.ndarray, image: np.ndarray, cap: int) -> None:
        n_tiles = int(image[4]) * -(-int(image[1]) // int(image[3]))
        self.starts = np.zeros(n_tiles + 1, dtype=np.int64)
        self.bound = np.zeros(n_tiles + 1, dtype=np.int64)
        tile_counts(order, bbox, image, cap, self.starts, self.bound)
        self.longest = max(int(self.starts.max()), 1)
        np.cumsum(self.starts, out=self.starts)
        np.cumsum(self.bound, out=self.bound)
        self.lists = np.empty(int(self.starts[-1]), dtype=np.int64)
        tile_fill(order, bbox, image, self.starts, self.lists)


def _composite(
    tiles: _Tiles, params: np.ndarray, bbox: np.ndarray, image: np.ndarray,
    config: RasterConfig, cap: int, ranges: _Ranges,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """(indptr, indices, weights) of the view: one pass into scratch when the bound fits
    ``SCRATCH_BYTES``, else (or on an overflow) a counting pass and a writing pass."""
    n_pix, n_tiles = int(image[0] * image[1]), tiles.starts.shape[0] - 1
    rules = np.array([config.alpha_min, config.alpha_max, config.transmittance_min])
    fixed = (tiles.starts, tiles.lists, params, bbox, image, rules, cap)
    counts = np.zeros(n_pix, dtype=np.int64)
    offsets = np.zeros(n_pix + 1, dtype=np.int64)

    def composite(mode: int, out: tuple[np.ndarray, np.ndarray], flags: np.ndarray) -> None:
        def task(first: int, last: int) -> None:
            room = make_room(int(image[2]), tiles.longest, cap)
            composite_tiles(*fixed, room, mode, counts, offsets, tiles.bound, *out, flags,
                            first, last)  # fmt: skip

        ranges.run(task, n_tiles, _TILE_RANGES_PER_THREAD)

    size = int(tiles.bound[-1])
    if size * 8 <= SCRATCH_BYTES:
        scratch = (np.empty(size, dtype=np.int32), np.empty(size, dtype=np.float32))
        overflow = np.zeros(n_tiles, dtype=np.uint8)
        composite(SCRATCH, scratch, overflow)
        if not overflow.any():
            indptr = np.zeros(n_pix + 1, dtype=np.int64)
            np.cumsum(counts, out=indptr[1:])
            out = (np.empty(indptr[-1], dtype=np.int32), np.empty(indptr[-1], dtype=np.float32))
            rows = int(image[1])
            ranges.run(lambda a, b: gather_rows(image, offsets, indptr, *scratch, *out, a, b), rows)
            return indptr, *out
        del scratch
    no_flags = np.zeros(0, dtype=np.uint8)
    composite(COUNT, (np.empty(0, dtype=np.int32), np.empty(0, dtype=np.float32)), no_flags)
    np.cumsum(counts, out=offsets[1:])
    out = (np.empty(offsets[-1], dtype=np.int32), np.empty(offsets[-1], dtype=np.float32))
    composite(FINAL, out, no_flags)
    return offsets, *out


def compute_contributors_numba(
    scene: GaussianScene, camera: Camera, config: RasterConfig, key: str
) -> Contributors:
    """Build the :class:`Contributors` of ``scene`` seen from ``camera`` with the kernels."""
    tiles_x = -(-camera.width // TILE_WIDTH)
    image = np.array([camera.width, camera.height, TILE_WIDTH, TILE_HEIGHT, tiles_x])
    cap = config.max_contributors if config.max_contributors is not None else scene.n + 1
    ranges = _Ranges(thread_count(config))
    try:
        order, depth, params, bbox = _project(scene, camera, config, ranges)
        tiles = _Tiles(order, bbox, image, cap)
        indptr, indices, weights = _composite(tiles, params, bbox, image, config, cap, ranges)
    finally:
        ranges.close()
    depths = np.zeros(scene.n, dtype=np.float32)
    depths[order] = depth[order]
    return Contributors(
        width=camera.width,
        height=camera.height,
        n_gaussians=scene.n,
        indptr=indptr,
        indices=indices,
        weights=weights,
        depths=depths,
        key=key,
    )
