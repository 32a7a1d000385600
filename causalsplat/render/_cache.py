"""Content-addressed cache of per-view :class:`Contributors`.

The key hashes what the weights depend on (the scene's geometry and opacity, not its
colours; the camera; the config, less its thread count), so an unchanged view is never
rebuilt, whichever objects carry it, and a changed array is never served stale weights.
"""

from __future__ import annotations

import hashlib
import threading
from collections import OrderedDict
from dataclasses import astuple, replace

import numpy as np

from causalsplat.io.types import Camera, GaussianScene
from causalsplat.render.config import RasterConfig
from causalsplat.render.types import Contributors

_LOCK = threading.Lock()
_CACHE: OrderedDict[str, Contributors] = OrderedDict()
_LIMIT = [512 * 2**20]  # bytes


def contributors_key(scene: GaussianScene, camera: Camera, config: RasterConfig) -> str:
    """Hex blake2b digest of the scene geometry, the camera and the config."""
    h = hashlib.blake2b(digest_size=20)
    for arr in (scene.means, scene.quats, scene.log_scales, scene.opacity_logits):
        h.update(str(arr.shape).encode())
        h.update(np.ascontiguousarray(arr).tobytes())
    cam = (camera.width, camera.height, camera.fx, camera.fy, camera.cx, camera.cy)
    h.update(repr(cam).encode())
    h.update(np.ascontiguousarray(camera.T_cam_world, dtype=np.float64).tobytes())
    h.update(repr(astuple(replace(config, threads=None))).encode())  # threads: speed only
    return h.hexdigest()


def cache_get(key: str) -> Contributors | None:
    with _LOCK:
        hit = _CACHE.get(key)
        if hit is not None:
            _CACHE.move_to_end(key)
        return hit


def cache_put(value: Contributors) -> None:
    with _LOCK:
        _CACHE[value.key] = value
        _CACHE.move_to_end(value.key)
        _evict()


def _evict() -> None:
    total = sum(c.nbytes for c in _CACHE.values())
    while _CACHE and total > _LIMIT[0]:
        _, old = _CACHE.popitem(last=False)
        total -= old.nbytes


def clear_contributor_cache() -> None:
    """Drop every cached :class:`Contributors`."""
    with _LOCK:
        _CACHE.clear()


def set_contributor_cache_limit(max_bytes: int) -> None:
    """Bound the cache to ``max_bytes`` (least recently used views are dropped first)."""
    with _LOCK:
        _LIMIT[0] = int(max_bytes)
        _evict()


def contributor_cache_info() -> tuple[int, int]:
    """(number of cached views, bytes they hold)."""
    with _LOCK:
        return len(_CACHE), sum(c.nbytes for c in _CACHE.values())
