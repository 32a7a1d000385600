"""Candidate pairs for the edge rules: KD-tree ball queries, or all pairs (the baseline).

Every rule can only hold between two entities within a reach that is bounded by the
larger of the two (see :mod:`causalsplat.graph.edges`). Each entity queries a KD-tree
(``scipy.spatial.cKDTree``) with its own reach and keeps the neighbours no larger than
itself, so every pair that can satisfy a rule is found (once) from its larger member and
the ball of a small entity stays small. Reaches are widened by a relative ``1e-9`` plus a
few ulps of the largest coordinate, so rounding inside the tree never loses a pair; the
rules are then evaluated exactly on the candidates.
"""

from __future__ import annotations

from collections.abc import Iterator
from itertools import chain

import numpy as np
import numpy.typing as npt
from scipy.spatial import cKDTree

from causalsplat.graph._edge_rules import footprint_radius, participates_in_proximity
from causalsplat.graph._edge_scene import CEILING, WALL, EdgeScene
from causalsplat.graph.config import EdgeConfig

Ints = npt.NDArray[np.int64]
Floats = npt.NDArray[np.float64]

_RELATIVE_MARGIN = 1e-9
_ULPS = 16 * np.finfo(np.float64).eps


def _ball_pairs(
    scene: EdgeScene, rows: Ints, points: Floats, reach: Floats, size: Floats, p: float
) -> tuple[Ints, Ints]:
    """Unordered pairs (scene rows) within the ``p``-norm reach of their larger member.

    ``reach`` must grow with ``size``. A pair is kept from the query of its member with
    the larger ``size`` (the higher row on ties), so each pair comes out exactly once.
    """
    empty = np.empty(0, dtype=np.int64)
    if rows.shape[0] < 2:
        return empty, empty
    radius = reach * (1.0 + _RELATIVE_MARGIN) + _ULPS * scene.coordinate_scale
    tree = cKDTree(points)
    found = tree.query_ball_point(points, r=radius, p=p, return_sorted=False)
    counts = np.fromiter(map(len, found), dtype=np.int64, count=len(found))
    total = int(counts.sum())
    src = np.repeat(np.arange(len(found), dtype=np.int64), counts)
    dst = np.fromiter(chain.from_iterable(found), dtype=np.int64, count=total)
    keep = (size[dst] < size[src]) | ((size[dst] == size[src]) & (dst < src))
    return rows[src[keep]], rows[dst[keep]]


def near_pairs(scene: EdgeScene, config: EdgeConfig) -> tuple[Ints, Ints]:
    """Pairs that may be ``near``: centroid distance ``< near_factor·(r_a + r_b)``."""
    rows = np.flatnonzero(participates_in_proximity(scene, config)).astype(np.int64)
    radius = footprint_radius(scene)[rows]
    reach = 2.0 * config.near_factor * radius
    return _ball_pairs(scene, rows, scene.centroid[rows], reach, radius, 2.0)


def vertical_pairs(scene: EdgeScene, config: EdgeConfig) -> tuple[Ints, Ints]:
    """Pairs that may be ``above``: horizontal centroid distance ``<= D``."""
    rows = np.flatnonzero(participates_in_proximity(scene, config)).astype(np.int64)
    diagonal = 2.0 * footprint_radius(scene)[rows]
    reach = np.minimum(
        np.maximum(
            config.horizontal_size_factor * diagonal,
            config.horizontal_min_fraction * scene.s_xy,
        ),
        config.horizontal_max_fraction * scene.s_xy,
    )
    points = scene.centroid[rows, :2]
    return _ball_pairs(scene, rows, points, reach, diagonal, 2.0)


def box_pairs(scene: EdgeScene, config: EdgeConfig) -> tuple[Ints, Ints]:
    """Pairs whose boxes may touch (support) or overlap (containment).

    Chebyshev distance of the box centres ``<= m_a + m_b + tol``, ``m`` the largest half
    extent of a box and ``tol`` the largest touch tolerance.
    """
    rows = np.flatnonzero((scene.kind != WALL) & (scene.kind != CEILING)).astype(np.int64)
    lo, hi = scene.lo[rows], scene.hi[rows]
    half = (hi - lo) * 0.5
    largest = half.max(axis=1) if rows.shape[0] else np.empty(0)
    reach = 2.0 * largest + scene.touch_cap
    centre = (lo + hi) * 0.5
    return _ball_pairs(scene, rows, centre, reach, largest, np.inf)


def all_pairs(n: int, block: int = 512) -> Iterator[tuple[Ints, Ints]]:
    """Every unordered pair ``(a, b)``, ``a < b``, in blocks of rows (the brute-force set)."""
    for start in range(0, max(n - 1, 0), block):
        rows = np.arange(start, min(start + block, n - 1), dtype=np.int64)
        counts = n - 1 - rows
        a = np.repeat(rows, counts)
        offsets = np.arange(a.shape[0], dtype=np.int64) - np.repeat(
            np.cumsum(counts) - counts, counts
        )
        yield a, a + 1 + offsets
