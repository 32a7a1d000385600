"""The edge rules, vectorised over arrays of entity pairs (the fast path's kernels).

Each kernel takes an :class:`EdgeScene`, the config and two ``(K,)`` int64 arrays of row
indices (unordered pairs, ``i[k] != j[k]``), tests both orientations of every pair and
returns one :class:`EdgeBatch` per relation type it emits. The arithmetic is written in
the same order as the scalar reference (:mod:`causalsplat.graph._edges_reference`), so the
two give bit-identical numbers. The rules themselves are stated in
:mod:`causalsplat.graph.edges`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from causalsplat.graph._edge_scene import FLOOR, OBJECT, EdgeScene
from causalsplat.graph.config import EdgeConfig
from graph_store import RelationType

Ints = npt.NDArray[np.int64]
Floats = npt.NDArray[np.float64]
Bools = npt.NDArray[np.bool_]


@dataclass(frozen=True, slots=True)
class EdgeBatch:
    """Relations of one type: row ``k`` reads "row ``src[k]`` is ``type`` row ``dst[k]``".

    ``src``/``dst``: ``(K,)`` int64 row indices into the :class:`EdgeScene`;
    ``evidence``: ``(name, (K,) float64 values)`` pairs, scene units or ratios.
    """

    type: RelationType
    src: Ints
    dst: Ints
    evidence: tuple[tuple[str, Floats], ...]

    def __len__(self) -> int:
        return int(self.src.shape[0])


def participates_in_proximity(scene: EdgeScene, config: EdgeConfig) -> Bools:
    """Rows that take part in above/below/near/next_to."""
    if config.relate_structural:
        return np.ones(scene.n, dtype=bool)
    participating: Bools = scene.kind == OBJECT
    return participating


def evaluate_pairs(scene: EdgeScene, config: EdgeConfig, i: Ints, j: Ints) -> list[EdgeBatch]:
    """Every rule on the pairs ``(i[k], j[k])``."""
    return [
        *vertical(scene, config, i, j),
        *support(scene, config, i, j),
        *containment(scene, config, i, j),
        *proximity(scene, config, i, j),
    ]


def centroid_distance(scene: EdgeScene, i: Ints, j: Ints) -> Floats:
    c = scene.centroid
    dx = c[i, 0] - c[j, 0]
    dy = c[i, 1] - c[j, 1]
    dz = c[i, 2] - c[j, 2]
    distance: Floats = np.sqrt(dx * dx + dy * dy + dz * dz)
    return distance


def vertical(scene: EdgeScene, config: EdgeConfig, i: Ints, j: Ints) -> list[EdgeBatch]:
    """``above``/``below``: ``|Δz|/d > tau_v`` and horizontal distance ``<= D``."""
    ok = participates_in_proximity(scene, config)
    keep = ok[i] & ok[j]
    i, j = i[keep], j[keep]
    c, size = scene.centroid, scene.hi - scene.lo
    dx = c[i, 0] - c[j, 0]
    dy = c[i, 1] - c[j, 1]
    dz = c[i, 2] - c[j, 2]
    h2 = dx * dx + dy * dy
    horizontal = np.sqrt(h2)
    distance = np.sqrt(h2 + dz * dz)
    positive = distance > 0
    ratio = np.where(positive, np.abs(dz) / np.where(positive, distance, 1.0), 0.0)
    bx = (size[i, 0] + size[j, 0]) * 0.5
    by = (size[i, 1] + size[j, 1]) * 0.5
    reach = config.horizontal_size_factor * np.sqrt(bx * bx + by * by)
    tolerance = np.minimum(
        np.maximum(reach, config.horizontal_min_fraction * scene.s_xy),
        config.horizontal_max_fraction * scene.s_xy,
    )
    hit = (ratio > config.tau_v) & (horizontal <= tolerance)
    up, down = hit & (dz > 0), hit & (dz < 0)
    upper = np.concatenate([i[up], j[down]])
    lower = np.concatenate([j[up], i[down]])
    pick = [np.concatenate([v[up], v[down]]) for v in (distance, horizontal, ratio, tolerance)]
    rise = np.concatenate([dz[up], -dz[down]])
    shared = tuple(
        zip(
            ("distance", "horizontal_distance", "vertical_ratio", "horizontal_tolerance"),
            pick,
            strict=True,
        )
    )
    return [
        EdgeBatch(RelationType.ABOVE, upper, lower, (*shared, ("height_difference", rise))),
        EdgeBatch(RelationType.BELOW, lower, upper, (*shared, ("height_difference", -rise))),
    ]


def overlap_fraction(lo_a: Floats, hi_a: Floats, lo_b: Floats, hi_b: Floats) -> Floats:
    """Per axis: the part of ``[lo_a, hi_a]`` inside ``[lo_b, hi_b]`` (0..1).

    A degenerate interval (``lo_a == hi_a``) counts 1 when it touches ``[lo_b, hi_b]``
    (closed) and 0 otherwise, the limit of the ratio as the interval shrinks.
    """
    extent = hi_a - lo_a
    inter = np.minimum(hi_a, hi_b) - np.maximum(lo_a, lo_b)
    proper = extent > 0
    ratio = np.maximum(inter, 0.0) / np.where(proper, extent, 1.0)
    return np.where(proper, ratio, np.where(inter >= 0, 1.0, 0.0))


def _footprint_overlap(scene: EdgeScene, a: Ints, b: Ints) -> Floats:
    lo, hi = scene.lo, scene.hi
    fx = overlap_fraction(lo[a, 0], hi[a, 0], lo[b, 0], hi[b, 0])
    fy = overlap_fraction(lo[a, 1], hi[a, 1], lo[b, 1], hi[b, 1])
    return fx * fy


def touch_tolerance(scene: EdgeScene, config: EdgeConfig, u: Ints, low: Ints) -> Floats:
    """``min(touch_fraction·S_z, touch_height_factor·max(h_u, h_l))`` per pair."""
    cap = np.full(u.shape, scene.touch_cap)
    if math.isinf(config.touch_height_factor):
        return cap
    height = scene.hi[:, 2] - scene.lo[:, 2]
    taller = np.maximum(height[u], height[low])
    clamped: Floats = np.minimum(cap, config.touch_height_factor * taller)
    return clamped


def _support_one(scene: EdgeScene, config: EdgeConfig, u: Ints, low: Ints) -> EdgeBatch:
    kind, lo, hi = scene.kind, scene.lo, scene.hi
    floor = kind[low] == FLOOR
    ok = (kind[u] == OBJECT) & ((kind[low] == OBJECT) | floor)
    above = (lo[u, 2] + hi[u, 2]) * 0.5 > (lo[low, 2] + hi[low, 2]) * 0.5
    gap = lo[u, 2] - hi[low, 2]
    tolerance = touch_tolerance(scene, config, u, low)
    on_top = above & (np.abs(gap) <= tolerance)
    in_slab = (lo[u, 2] >= lo[low, 2] - tolerance) & (lo[u, 2] <= hi[low, 2] + tolerance)
    touch = np.where(floor, in_slab, on_top)
    overlap = _footprint_overlap(scene, u, low)
    hit = ok & touch & (overlap >= config.support_overlap)
    u, low = u[hit], low[hit]
    evidence = (
        ("distance", centroid_distance(scene, u, low)),
        ("gap", gap[hit]),
        ("overlap", overlap[hit]),
        ("touch_tolerance", tolerance[hit]),
    )
    return EdgeBatch(RelationType.SUPPORTED_BY, u, low, evidence)


def support(scene: EdgeScene, config: EdgeConfig, i: Ints, j: Ints) -> list[EdgeBatch]:
    """``supported_by``/``supports``: touching along the up axis and overlapping on top."""
    first, second = _support_one(scene, config, i, j), _support_one(scene, config, j, i)
    src = np.concatenate([first.src, second.src])
    dst = np.concatenate([first.dst, second.dst])
    evidence = tuple(
        (name, np.concatenate([a, b]))
        for (name, a), (_, b) in zip(first.evidence, second.evidence, strict=True)
    )
    return [
        EdgeBatch(RelationType.SUPPORTED_BY, src, dst, evidence),
        EdgeBatch(RelationType.SUPPORTS, dst, src, evidence),
    ]


def _volume(scene: EdgeScene, rows: Ints) -> Floats:
    size = scene.hi[rows] - scene.lo[rows]
    return size[:, 0] * size[:, 1] * size[:, 2]


def containment(scene: EdgeScene, config: EdgeConfig, i: Ints, j: Ints) -> list[EdgeBatch]:
    """``inside``/``contains``: the smaller box lies mostly inside the larger one."""
    both = (scene.kind[i] == OBJECT) & (scene.kind[j] == OBJECT)
    i, j = i[both], j[both]
    vi, vj = _volume(scene, i), _volume(scene, j)
    small_i = vi < vj
    inner = np.where(small_i, i, j)
    outer = np.where(small_i, j, i)
    v_in, v_out = np.where(small_i, vi, vj), np.where(small_i, vj, vi)
    strict = v_in < v_out
    lo, hi = scene.lo, scene.hi
    overlap = overlap_fraction(lo[inner, 0], hi[inner, 0], lo[outer, 0], hi[outer, 0])
    for axis in (1, 2):
        overlap = overlap * overlap_fraction(
            lo[inner, axis], hi[inner, axis], lo[outer, axis], hi[outer, axis]
        )
    hit = strict & (overlap >= config.contain_overlap)
    inner, outer = inner[hit], outer[hit]
    evidence = (
        ("distance", centroid_distance(scene, inner, outer)),
        ("overlap", overlap[hit]),
        ("volume_ratio", v_in[hit] / v_out[hit]),
    )
    return [
        EdgeBatch(RelationType.INSIDE, inner, outer, evidence),
        EdgeBatch(RelationType.CONTAINS, outer, inner, evidence),
    ]


def footprint_radius(scene: EdgeScene) -> Floats:
    """``(N,)`` half-diagonal of each box's footprint, scene units."""
    size = scene.hi - scene.lo
    return 0.5 * np.sqrt(size[:, 0] * size[:, 0] + size[:, 1] * size[:, 1])


def proximity(scene: EdgeScene, config: EdgeConfig, i: Ints, j: Ints) -> list[EdgeBatch]:
    """``near`` (centroid distance below ``near_factor·(r_i + r_j)``) and ``next_to``."""
    ok = participates_in_proximity(scene, config)
    keep = ok[i] & ok[j]
    i, j = i[keep], j[keep]
    radius = footprint_radius(scene)
    distance = centroid_distance(scene, i, j)
    threshold = config.near_factor * (radius[i] + radius[j])
    near = distance < threshold
    lo, hi = scene.lo, scene.hi
    z_overlap = np.minimum(hi[i, 2], hi[j, 2]) - np.maximum(lo[i, 2], lo[j, 2])
    beside = near & (z_overlap > 0)
    both = [np.concatenate([i[near], j[near]]), np.concatenate([j[near], i[near]])]
    near_ev = tuple(
        (name, np.concatenate([v[near], v[near]]))
        for name, v in (("distance", distance), ("near_threshold", threshold))
    )
    side = [np.concatenate([i[beside], j[beside]]), np.concatenate([j[beside], i[beside]])]
    side_ev = tuple(
        (name, np.concatenate([v[beside], v[beside]]))
        for name, v in (
            ("distance", distance),
            ("near_threshold", threshold),
            ("vertical_overlap", z_overlap),
        )
    )
    return [
        EdgeBatch(RelationType.NEAR, both[0], both[1], near_ev),
        EdgeBatch(RelationType.NEXT_TO, side[0], side[1], side_ev),
    ]
