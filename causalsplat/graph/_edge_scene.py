"""Entities as float64 arrays for the edge rules (shared by the fast path and the reference)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from causalsplat.graph.config import EdgeConfig
from causalsplat.graph.errors import EdgeInputError
from graph_store import Entity

#: Entity kinds (``EdgeScene.kind``).
OBJECT, FLOOR, WALL, CEILING = 0, 1, 2, 3

#: Largest coordinate magnitude accepted: squares of differences stay far below overflow.
MAX_COORDINATE = 1e100

_AXES = {"x": (1, 2, 0), "y": (2, 0, 1), "z": (0, 1, 2)}


@dataclass(frozen=True, slots=True)
class EdgeScene:
    """The entities of one scene, ready for the rules; axes permuted so the up axis is last.

    Attributes:
        ids: ``(N,)`` int64, the entity ids (rows follow the input order).
        centroid: ``(N, 3)`` float64, scene units, horizontal axes first, up axis last.
        lo: ``(N, 3)`` float64, box minimum corner, same frame.
        hi: ``(N, 3)`` float64, box maximum corner, same frame.
        kind: ``(N,)`` int8, ``OBJECT``, ``FLOOR``, ``WALL`` or ``CEILING``.
        s_xy: scene units, horizontal diagonal of the centroid extent (all entities).
        s_z: scene units, extent of the union of all boxes along the up axis.
        touch_cap: scene units, ``touch_fraction · s_z``: the largest touch tolerance.
        coordinate_scale: the largest coordinate magnitude (for rounding margins).
    """

    ids: npt.NDArray[np.int64]
    centroid: npt.NDArray[np.float64]
    lo: npt.NDArray[np.float64]
    hi: npt.NDArray[np.float64]
    kind: npt.NDArray[np.int8]
    s_xy: float
    s_z: float
    touch_cap: float
    coordinate_scale: float

    @property
    def n(self) -> int:
        return int(self.ids.shape[0])


def prepare_scene(entities: Sequence[Entity], config: EdgeConfig, up_axis: str) -> EdgeScene:
    """Check the entities and lay them out as arrays (raises :class:`EdgeInputError`)."""
    if up_axis not in _AXES:
        raise EdgeInputError(f"up axis must be 'x', 'y' or 'z', got {up_axis!r}")
    order = list(_AXES[up_axis])
    seen: set[int] = set()
    for position, e in enumerate(entities):
        if not isinstance(e, Entity):
            raise EdgeInputError(f"entities[{position}] is a {type(e).__name__}, not an Entity")
        if e.id in seen:
            raise EdgeInputError(f"duplicate entity id {e.id}")
        seen.add(e.id)
    n = len(entities)
    ids = np.fromiter((e.id for e in entities), dtype=np.int64, count=n)
    flat = np.array(
        [(*e.centroid, *e.bbox_min, *e.bbox_max) for e in entities], dtype=np.float64
    ).reshape(n, 9)
    scale = float(np.abs(flat).max()) if n else 0.0
    if scale > MAX_COORDINATE:
        worst = int(np.abs(flat).max(axis=1).argmax())
        raise EdgeInputError(
            f"entity {int(ids[worst])} has a coordinate of magnitude {scale:.3g}, beyond the"
            f" supported {MAX_COORDINATE:g} scene units (rescale the scene)"
        )
    centroid = np.ascontiguousarray(flat[:, 0:3][:, order])
    lo = np.ascontiguousarray(flat[:, 3:6][:, order])
    hi = np.ascontiguousarray(flat[:, 6:9][:, order])
    kind = np.fromiter((_kind(e.category, config) for e in entities), dtype=np.int8, count=n)
    s_xy = s_z = 0.0
    if n:
        ex = float(centroid[:, 0].max()) - float(centroid[:, 0].min())
        ey = float(centroid[:, 1].max()) - float(centroid[:, 1].min())
        s_xy = float(np.sqrt(ex * ex + ey * ey))
        s_z = float(hi[:, 2].max()) - float(lo[:, 2].min())
    return EdgeScene(
        ids=ids,
        centroid=centroid,
        lo=lo,
        hi=hi,
        kind=kind,
        s_xy=s_xy,
        s_z=s_z,
        touch_cap=config.touch_fraction * s_z,
        coordinate_scale=scale,
    )


def _kind(category: str, config: EdgeConfig) -> int:
    key = category.strip().lower()
    if key in config.floor_categories:
        return FLOOR
    if key in config.wall_categories:
        return WALL
    if key in config.ceiling_categories:
        return CEILING
    return OBJECT
