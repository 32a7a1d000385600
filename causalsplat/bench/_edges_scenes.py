"""Random multi-room scenes for the edge benchmark and tests (deterministic by seed).

A scene is a grid of 6 m x 6 m x 2.5 m rooms. Each room has a floor, four walls, pieces of
furniture standing on the floor, and small objects resting on the furniture (some on
other small objects, some inside a piece of furniture). Boxes carry the kind of noise
reconstructed boxes have: bottoms a few centimetres off their support, centroids off the
box centre.
"""

from __future__ import annotations

import numpy as np

from graph_store import Entity

ROOM = 6.0
HEIGHT = 2.5
PER_ROOM = 40  # 5 structural + 15 furniture + 20 small objects
FURNITURE = 15


def random_rooms(n: int, *, seed: int = 0) -> tuple[Entity, ...]:
    """``n`` entities (ids ``0..n-1``) in ``ceil(n / 40)`` rooms on a square grid."""
    rng = np.random.default_rng(seed)
    rooms = max(1, -(-n // PER_ROOM))
    side = int(np.ceil(np.sqrt(rooms)))
    boxes: list[tuple[str, np.ndarray, np.ndarray]] = []
    for r in range(rooms):
        origin = np.array([(r % side) * ROOM, (r // side) * ROOM, 0.0])
        boxes += _room(rng, origin)
    out = []
    for k, (category, lo, hi) in enumerate(boxes[:n]):
        jitter = rng.uniform(-0.1, 0.1, 3) * (hi - lo)
        centroid = (lo + hi) / 2 + jitter
        out.append(Entity(k, category, tuple(centroid), tuple(lo), tuple(hi), external_id=str(k)))
    return tuple(out)


def _room(rng: np.random.Generator, origin: np.ndarray) -> list[tuple[str, np.ndarray, np.ndarray]]:
    t = 0.05
    boxes = [("floor", origin + np.array([0, 0, -t]), origin + np.array([ROOM, ROOM, 0]))]
    for lo, hi in (
        ([0, 0, 0], [ROOM, t, HEIGHT]),
        ([0, ROOM - t, 0], [ROOM, ROOM, HEIGHT]),
        ([0, 0, 0], [t, ROOM, HEIGHT]),
        ([ROOM - t, 0, 0], [ROOM, ROOM, HEIGHT]),
    ):
        boxes.append(("wall", origin + np.array(lo), origin + np.array(hi)))
    furniture: list[tuple[np.ndarray, np.ndarray]] = []
    for _ in range(FURNITURE):
        size = np.array([*rng.uniform(0.4, 2.0, 2), rng.uniform(0.4, 1.2)])
        xy = rng.uniform(0.1, ROOM - 0.1 - size[:2])
        base = origin + np.array([xy[0], xy[1], rng.uniform(-0.03, 0.03)])
        furniture.append((base, base + size))
        boxes.append(("furniture", base, base + size))
    small: list[tuple[np.ndarray, np.ndarray]] = []
    for _ in range(PER_ROOM - 5 - FURNITURE):
        size = rng.uniform(0.05, 0.4, 3)
        roll = rng.uniform()
        if roll < 0.2 and small:  # stacked on another small object
            base_lo, base_hi = small[int(rng.integers(len(small)))]
        else:
            base_lo, base_hi = furniture[int(rng.integers(len(furniture)))]
        span = np.maximum(base_hi[:2] - base_lo[:2] - size[:2], 0.0)
        xy = base_lo[:2] + rng.uniform(0, 1, 2) * span
        if 0.2 <= roll < 0.35 and base_hi[2] - base_lo[2] > size[2]:  # inside the furniture
            z = base_lo[2] + rng.uniform(0, base_hi[2] - base_lo[2] - size[2])
        else:
            z = base_hi[2] + rng.uniform(-0.05, 0.02)
        corner = np.array([xy[0], xy[1], z])
        small.append((corner, corner + size))
        boxes.append(("object", corner, corner + size))
    return boxes
