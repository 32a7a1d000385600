"""Cameras for a ScanNet scan: the real posed frames, and a generated walk-through.

Real frames: ``T_world_cam = axis_align_matrix @ camera_to_world_unaligned`` (OpenCV, so
used as is), intrinsics scaled from the photo size to the output size per axis.

Walk-through: a 2D occupancy map of the scan on a ``cell_m`` grid marks floor cells (vertices
within 0.1 m of the floor height, holes closed) and obstacle cells (vertices 0.1-2.0 m above
the floor). Eye positions are floor cells at least ``clearance_m`` from every obstacle, in
the largest connected free region, spread out by farthest-point sampling and visited in
nearest-neighbour order; the eye is ``eye_height_m`` above the floor. Each view looks at the
annotated object (not wall, floor or ceiling) seen least so far among those 1-4.5 m away
whose centre is not hidden behind scan vertices, or at the room centre when there is none.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from causalsplat.io.types import Camera
from causalsplat.scannet.source import ScanNetSource

_UP = np.array([0.0, 0.0, 1.0])
_BACKGROUND_LABELS = frozenset({"wall", "floor", "ceiling"})


def real_cameras(source: ScanNetSource, width: int, height: int) -> tuple[Camera, ...]:
    """One camera per real frame, named ``real_<image stem>``, resized to ``width x height``."""
    fx, fy, cx, cy = source.intrinsics
    sx, sy = width / source.image_size[0], height / source.image_size[1]
    cams = []
    for frame in source.frames:
        T_cam_world = np.linalg.inv(frame.T_world_cam)
        T_cam_world[3] = (0.0, 0.0, 0.0, 1.0)
        name = f"real_{frame.image.stem}"
        cams.append(Camera(name, width, height, fx * sx, fy * sy, cx * sx, cy * sy, T_cam_world))
    return tuple(cams)


def _free_cells(
    xyz: np.ndarray, floor_z: float, cell_m: float, clearance_m: float
) -> tuple[np.ndarray, np.ndarray]:
    """(K, 2) xy centres of free floor cells, and the grid origin."""
    origin = xyz[:, :2].min(axis=0)
    ij = np.floor((xyz[:, :2] - origin) / cell_m).astype(np.int64)
    shape = tuple(ij.max(axis=0) + 1)
    height = xyz[:, 2] - floor_z
    floor = np.zeros(shape, dtype=bool)
    obstacle = np.zeros(shape, dtype=bool)
    low = height < 0.1
    floor[ij[low, 0], ij[low, 1]] = True
    mid = (height >= 0.1) & (height < 2.0)
    obstacle[ij[mid, 0], ij[mid, 1]] = True
    floor = ndimage.binary_closing(floor, iterations=2) & ndimage.binary_fill_holes(floor)
    distance = ndimage.distance_transform_edt(~obstacle) * cell_m
    free = floor & (distance >= clearance_m)
    regions, count = ndimage.label(free)
    if count == 0:
        return np.zeros((0, 2)), origin
    sizes = ndimage.sum(free, regions, index=np.arange(1, count + 1))
    keep = regions == (1 + int(np.argmax(sizes)))
    cells = np.argwhere(keep)
    return origin + (cells + 0.5) * cell_m, origin


def _spread(points: np.ndarray, n: int) -> np.ndarray:
    """``n`` points by farthest-point sampling (from the one nearest the centroid), then
    ordered as a walk by greedy nearest neighbour."""
    if points.shape[0] <= n:
        chosen = list(range(points.shape[0]))
    else:
        first = int(np.argmin(np.linalg.norm(points - points.mean(axis=0), axis=1)))
        chosen = [first]
        dist = np.linalg.norm(points - points[first], axis=1)
        while len(chosen) < n:
            nxt = int(np.argmax(dist))
            chosen.append(nxt)
            dist = np.minimum(dist, np.linalg.norm(points - points[nxt], axis=1))
    pts = points[chosen]
    order = [0]
    left = set(range(1, pts.shape[0]))
    while left:
        last = pts[order[-1]]
        nxt = min(left, key=lambda k: (float(np.linalg.norm(pts[k] - last)), k))
        order.append(nxt)
        left.remove(nxt)
    return pts[order]


def _visible(tree: cKDTree, eye: np.ndarray, target: np.ndarray, radius: float) -> bool:
    steps = np.linspace(0.05, 0.8, 16)[:, None]
    samples = eye + steps * (target - eye)
    hits = tree.query_ball_point(samples, r=radius, return_length=True)
    return bool(np.all(np.asarray(hits) == 0))


def walk_cameras(
    source: ScanNetSource,
    n_views: int,
    width: int,
    height: int,
    *,
    fov_y_deg: float = 50.0,
    eye_height_m: float = 1.5,
    cell_m: float = 0.1,
    clearance_m: float = 0.5,
) -> tuple[Camera, ...]:
    """``n_views`` walk-through cameras (module docstring), named ``walk_000``..."""
    if n_views <= 0:
        return ()
    floor_z = float(np.percentile(source.xyz[:, 2], 1.0))
    cells, _ = _free_cells(source.xyz, floor_z, cell_m, clearance_m)
    if cells.shape[0] == 0:
        lo, hi = source.xyz[:, :2].min(axis=0), source.xyz[:, :2].max(axis=0)
        cells = ((lo + hi) / 2)[None]
    eyes_xy = _spread(cells, n_views)
    tree = cKDTree(source.xyz)
    targets = [o for o in source.objects if o.label not in _BACKGROUND_LABELS]
    seen = {o.id: 0 for o in targets}
    room_centre = np.append(source.xyz[:, :2].mean(axis=0), floor_z + 1.0)
    cams = []
    for k in range(n_views):
        eye = np.append(eyes_xy[k % eyes_xy.shape[0]], floor_z + eye_height_m)
        best = None
        for obj in sorted(targets, key=lambda o: (seen[o.id], o.id)):
            aim = np.asarray(obj.center)
            dist = float(np.linalg.norm(aim[:2] - eye[:2]))
            if 1.0 <= dist <= 4.5 and _visible(tree, eye, aim, 0.05):
                best = obj
                break
        if best is not None:
            seen[best.id] += 1
            aim = np.asarray(best.center)
        else:
            aim = room_centre
        cams.append(Camera.look_at(f"walk_{k:03d}", eye, aim, _UP, width, height, fov_y_deg))
    return tuple(cams)
