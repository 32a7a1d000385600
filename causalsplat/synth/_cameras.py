"""Cameras inside a synthetic room, each looking at something.

Every fourth view is an overview from high in a corner, looking at the middle of the room's
contents; the others each look at one entity (cycling through a shuffled list of all
furniture and small objects) from a random direction 15-55 degrees above the horizontal, at
a distance that grows with the entity's size. A candidate eye is kept only when it is inside
the room, at least 0.35 m from every box, and the segment from the eye to the
entity's centre crosses no other box, so the entity is visible.
"""

from __future__ import annotations

import numpy as np

from causalsplat.io.types import Camera
from causalsplat.synth._layout import RoomLayout, SynthObject
from causalsplat.synth.config import SynthConfig
from causalsplat.synth.vocab import Kind

_UP = np.array([0.0, 0.0, 1.0])
_TRIES = 80
_BOX_CLEARANCE_M = 0.35


def view_name(index: int) -> str:
    """Image stem of view ``index`` (``view_000``...)."""
    return f"view_{index:03d}"


def _segment_hits_box(p: np.ndarray, q: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> bool:
    """Slab test: does the segment p->q pass through the box [lo, hi]?"""
    d = q - p
    t0, t1 = 0.0, 1.0
    for axis in range(3):
        if abs(d[axis]) < 1e-12:
            if p[axis] < lo[axis] or p[axis] > hi[axis]:
                return False
            continue
        a = (lo[axis] - p[axis]) / d[axis]
        b = (hi[axis] - p[axis]) / d[axis]
        t0, t1 = max(t0, min(a, b)), min(t1, max(a, b))
        if t0 > t1:
            return False
    return True


def _eye_ok(eye: np.ndarray, target: SynthObject, layout: RoomLayout, margin: float) -> bool:
    lx, ly, h = layout.room_size
    if not (margin <= eye[0] <= lx - margin and margin <= eye[1] <= ly - margin):
        return False
    if not 0.3 <= eye[2] <= h - 0.1:
        return False
    aim = np.asarray(target.center)
    for obj in layout.objects:
        if obj.kind is Kind.STRUCTURE:
            continue
        if np.all(eye > obj.lo - _BOX_CLEARANCE_M) and np.all(eye < obj.hi + _BOX_CLEARANCE_M):
            return False
        if obj.id != target.id and _segment_hits_box(eye, aim, obj.lo, obj.hi):
            return False
    return True


def _object_view(
    target: SynthObject, layout: RoomLayout, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray] | None:
    extent = float(np.linalg.norm(target.size))
    aim = np.asarray(target.center)
    for attempt in range(_TRIES):
        relax = attempt / _TRIES
        azimuth = rng.uniform(0, 2 * np.pi)
        elevation = np.deg2rad(rng.uniform(15, 55))
        dist = max(0.8, 1.6 * extent) * rng.uniform(1.0, 1.8) * (1 - 0.4 * relax)
        direction = np.array(
            [np.cos(elevation) * np.cos(azimuth), np.cos(elevation) * np.sin(azimuth), 0.0]
        )
        direction[2] = np.sin(elevation)
        eye = aim + dist * direction
        if _eye_ok(eye, target, layout, margin=0.25):
            return eye, aim + 0.03 * rng.standard_normal(3)
    return None


def _overview(
    index: int, layout: RoomLayout, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    lx, ly, h = layout.room_size
    corner = (index // 4) % 4
    x = 0.3 if corner in (0, 3) else lx - 0.3
    y = 0.3 if corner in (0, 1) else ly - 0.3
    eye = np.array([x, y, h - 0.2]) + 0.05 * rng.standard_normal(3)
    things = [np.asarray(o.center) for o in layout.objects if o.kind is not Kind.STRUCTURE]
    target = np.mean(things, axis=0) if things else np.array([lx / 2, ly / 2, 0.5])
    return eye, target


def generate_cameras(
    layout: RoomLayout, cfg: SynthConfig, rng: np.random.Generator
) -> tuple[Camera, ...]:
    """``cfg.n_views`` cameras (module docstring), named :func:`view_name`."""
    things = [o for o in layout.objects if o.kind is not Kind.STRUCTURE]
    order = [things[i] for i in rng.permutation(len(things))]
    cams: list[Camera] = []
    k = 0
    for index in range(cfg.n_views):
        pose = None
        if index % 4 != 3 and order:
            for _ in range(len(order)):
                target = order[k % len(order)]
                k += 1
                pose = _object_view(target, layout, rng)
                if pose is not None:
                    break
        if pose is None:
            pose = _overview(index, layout, rng)
        eye, aim = pose
        cams.append(
            Camera.look_at(view_name(index), eye, aim, _UP, cfg.width, cfg.height, cfg.fov_y_deg)
        )
    return tuple(cams)
