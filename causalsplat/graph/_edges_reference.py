"""The edge rules written plainly: a scalar loop over every pair (the reference).

Obviously correct and slow (``O(N²)`` Python work): it is what the fast path in
:mod:`causalsplat.graph.edges` is held against. The arithmetic follows the same order as
the vectorised kernels, so both give bit-identical evidence; the rules are stated in
:mod:`causalsplat.graph.edges`.
"""

from __future__ import annotations

import math

from causalsplat.graph._edge_scene import FLOOR, OBJECT, EdgeScene
from causalsplat.graph.config import EdgeConfig
from graph_store import RelationType

Box = tuple[list[float], list[float], list[float]]  # centroid, lo, hi
Found = dict[tuple[int, RelationType, int], dict[str, float]]


def reference_relations(scene: EdgeScene, config: EdgeConfig) -> Found:
    """``{(src row, type, dst row): evidence}`` for every relation of the scene."""
    boxes: list[Box] = [
        (scene.centroid[k].tolist(), scene.lo[k].tolist(), scene.hi[k].tolist())
        for k in range(scene.n)
    ]
    kinds = scene.kind.tolist()
    found: Found = {}
    for a in range(scene.n):
        for b in range(a + 1, scene.n):
            _pair(scene, config, boxes, kinds, a, b, found)
    return found


def _pair(
    scene: EdgeScene,
    config: EdgeConfig,
    boxes: list[Box],
    kinds: list[int],
    a: int,
    b: int,
    found: Found,
) -> None:
    proximal = config.relate_structural or (kinds[a] == OBJECT and kinds[b] == OBJECT)
    if proximal:
        _vertical(scene, config, boxes[a], boxes[b], a, b, found)
        _proximity(config, boxes[a], boxes[b], a, b, found)
    for upper, lower in ((a, b), (b, a)):
        if kinds[upper] == OBJECT and kinds[lower] in (OBJECT, FLOOR):
            floor = kinds[lower] == FLOOR
            _support(scene, config, boxes[upper], boxes[lower], upper, lower, found, floor=floor)
    if kinds[a] == OBJECT and kinds[b] == OBJECT:
        _containment(config, boxes[a], boxes[b], a, b, found)


def _distance(p: list[float], q: list[float]) -> float:
    dx, dy, dz = p[0] - q[0], p[1] - q[1], p[2] - q[2]
    return math.sqrt(dx * dx + dy * dy + dz * dz)


def _vertical(
    scene: EdgeScene, config: EdgeConfig, box_a: Box, box_b: Box, a: int, b: int, found: Found
) -> None:
    (ca, lo_a, hi_a), (cb, lo_b, hi_b) = box_a, box_b
    dx, dy, dz = ca[0] - cb[0], ca[1] - cb[1], ca[2] - cb[2]
    h2 = dx * dx + dy * dy
    horizontal = math.sqrt(h2)
    distance = math.sqrt(h2 + dz * dz)
    ratio = abs(dz) / distance if distance > 0 else 0.0
    bx = ((hi_a[0] - lo_a[0]) + (hi_b[0] - lo_b[0])) * 0.5
    by = ((hi_a[1] - lo_a[1]) + (hi_b[1] - lo_b[1])) * 0.5
    reach = config.horizontal_size_factor * math.sqrt(bx * bx + by * by)
    tolerance = min(
        max(reach, config.horizontal_min_fraction * scene.s_xy),
        config.horizontal_max_fraction * scene.s_xy,
    )
    if not (ratio > config.tau_v and horizontal <= tolerance and dz != 0):
        return
    upper, lower, rise = (a, b, dz) if dz > 0 else (b, a, -dz)
    shared = {
        "distance": distance,
        "horizontal_distance": horizontal,
        "vertical_ratio": ratio,
        "horizontal_tolerance": tolerance,
    }
    found[(upper, RelationType.ABOVE, lower)] = {**shared, "height_difference": rise}
    found[(lower, RelationType.BELOW, upper)] = {**shared, "height_difference": -rise}


def _fraction(lo_a: float, hi_a: float, lo_b: float, hi_b: float) -> float:
    extent = hi_a - lo_a
    inter = min(hi_a, hi_b) - max(lo_a, lo_b)
    if extent > 0:
        return max(inter, 0.0) / extent
    return 1.0 if inter >= 0 else 0.0


def _support(
    scene: EdgeScene,
    config: EdgeConfig,
    box_u: Box,
    box_l: Box,
    upper: int,
    lower: int,
    found: Found,
    *,
    floor: bool,
) -> None:
    (cu, lo_u, hi_u), (cl, lo_l, hi_l) = box_u, box_l
    gap = lo_u[2] - hi_l[2]
    tolerance = scene.touch_cap
    if not math.isinf(config.touch_height_factor):
        taller = max(hi_u[2] - lo_u[2], hi_l[2] - lo_l[2])
        tolerance = min(tolerance, config.touch_height_factor * taller)
    if floor:  # the bottom lies in the floor's slab, widened by the tolerance
        touch = lo_l[2] - tolerance <= lo_u[2] <= hi_l[2] + tolerance
    else:  # the higher box's bottom is within the tolerance of the lower box's top
        higher = (lo_u[2] + hi_u[2]) * 0.5 > (lo_l[2] + hi_l[2]) * 0.5
        touch = higher and abs(gap) <= tolerance
    overlap = _fraction(lo_u[0], hi_u[0], lo_l[0], hi_l[0]) * _fraction(
        lo_u[1], hi_u[1], lo_l[1], hi_l[1]
    )
    if touch and overlap >= config.support_overlap:
        evidence = {
            "distance": _distance(cu, cl),
            "gap": gap,
            "overlap": overlap,
            "touch_tolerance": tolerance,
        }
        found[(upper, RelationType.SUPPORTED_BY, lower)] = evidence
        found[(lower, RelationType.SUPPORTS, upper)] = dict(evidence)


def _containment(config: EdgeConfig, box_a: Box, box_b: Box, a: int, b: int, found: Found) -> None:
    volumes = []
    for _, lo, hi in (box_a, box_b):
        volumes.append((hi[0] - lo[0]) * (hi[1] - lo[1]) * (hi[2] - lo[2]))
    if volumes[0] == volumes[1]:
        return
    inner, outer = (a, b) if volumes[0] < volumes[1] else (b, a)
    (ci, lo_i, hi_i), (co, lo_o, hi_o) = (box_a, box_b) if inner == a else (box_b, box_a)
    overlap = _fraction(lo_i[0], hi_i[0], lo_o[0], hi_o[0])
    for axis in (1, 2):
        overlap = overlap * _fraction(lo_i[axis], hi_i[axis], lo_o[axis], hi_o[axis])
    if overlap >= config.contain_overlap:
        v_in, v_out = min(volumes), max(volumes)
        evidence = {
            "distance": _distance(ci, co),
            "overlap": overlap,
            "volume_ratio": v_in / v_out,
        }
        found[(inner, RelationType.INSIDE, outer)] = evidence
        found[(outer, RelationType.CONTAINS, inner)] = dict(evidence)


def _radius(lo: list[float], hi: list[float]) -> float:
    sx, sy = hi[0] - lo[0], hi[1] - lo[1]
    return 0.5 * math.sqrt(sx * sx + sy * sy)


def _proximity(config: EdgeConfig, box_a: Box, box_b: Box, a: int, b: int, found: Found) -> None:
    (ca, lo_a, hi_a), (cb, lo_b, hi_b) = box_a, box_b
    ra, rb = _radius(lo_a, hi_a), _radius(lo_b, hi_b)
    distance = _distance(ca, cb)
    threshold = config.near_factor * (ra + rb)
    if not distance < threshold:
        return
    near = {"distance": distance, "near_threshold": threshold}
    found[(a, RelationType.NEAR, b)] = near
    found[(b, RelationType.NEAR, a)] = dict(near)
    z_overlap = min(hi_a[2], hi_b[2]) - max(lo_a[2], lo_b[2])
    if z_overlap > 0:
        beside = {**near, "vertical_overlap": z_overlap}
        found[(a, RelationType.NEXT_TO, b)] = beside
        found[(b, RelationType.NEXT_TO, a)] = dict(beside)
