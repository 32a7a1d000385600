"""What the reasoner knows about one scene, computed once and reused across questions.

A :class:`SceneContext` wraps a :class:`~graph_store.SceneGraph` and keeps an executor for
it (by default the ``memory`` executor: the graph is already in memory, and it imports
no networkx; the tests hold it to the networkx reference), the scene's
distinct categories and attribute values, its centre, and a cache where the backends put
what they derive from the scene (the category index, category embeddings). The
per-Gaussian labels are read from the store only when an answer needs them.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from causalsplat.colors import hex_to_rgb
from causalsplat.reason.errors import UnlabelledSceneError
from graph_store import Entity, SceneGraph
from queries import DEFAULT_CONFIG, Executor, GraphQuery, QueryConfig, QueryResult, make_executor

if TYPE_CHECKING:
    import numpy as np

Vec3 = tuple[float, float, float]


#: How near a wall (scene units) an entity's footprint must come to stand against it.
WALL_CONTACT = 0.25

#: The category of an entity nobody named (the build's ``graph.nodes.UNLABELLED``).
UNLABELLED = "object"


class SceneContext:
    """One scene, ready for questions.

    Attributes:
        graph: the scene graph.
        scene_id: its id.
        config: the query semantics in force (structural categories, affordance key).
        categories: distinct entity categories, sorted.
        centre: ``(x, y, z)`` centre of the union of entity boxes (world frame, scene units),
            the same point the query language uses as its default eye.
        half_diagonal: half the horizontal (x, y) diagonal of that union (scene units).
        cache: per-scene memo for the backends (keys are private to each backend).
    """

    def __init__(
        self,
        graph: SceneGraph,
        *,
        executor: Executor | None = None,
        labels: Callable[[], np.ndarray | None] | None = None,
        config: QueryConfig = DEFAULT_CONFIG,
    ) -> None:
        self.graph = graph
        self.scene_id = graph.scene_id
        self.config = config
        self._executor = executor
        self._labels_loader = labels
        self._labels: np.ndarray | None = None
        self._labels_read = False
        self.by_id: dict[int, Entity] = {e.id: e for e in graph.entities}
        self.categories: tuple[str, ...] = tuple(sorted({e.category for e in graph.entities}))
        self.centre, self.half_diagonal = _centre(graph.entities)
        self.cache: dict[str, Any] = {}

    def __repr__(self) -> str:
        return f"SceneContext({self.scene_id!r}, {len(self.by_id)} entities)"

    def require_categories(self) -> None:
        """Raise :class:`UnlabelledSceneError` when no entity has a category (every one is
        the unlabelled ``object`` and none stores an affordance or caption)."""
        if not self.by_id or set(self.categories) != {UNLABELLED}:
            return
        if any(
            a.key in ("affordance", "caption") for e in self.by_id.values() for a in e.attributes
        ):
            return
        raise UnlabelledSceneError(
            f"scene {self.scene_id!r} has no categories: its {len(self.by_id)} entities were"
            " built from masks without labels. Rebuild with --labeler vlm (a vision-language"
            " model names each entity) or with labels in the masks"
        )

    # -- running programs ----------------------------------------------------------------

    @property
    def executor(self) -> Executor:
        if self._executor is None:
            self._executor = make_executor(
                self.graph, self.scene_id, executor="memory", config=self.config
            )
        return self._executor

    def run(self, program: GraphQuery) -> QueryResult:
        """Run a program on this scene."""
        return self.executor.run(program)

    # -- what the scene holds ------------------------------------------------------------

    def attribute_values(self, key: str) -> tuple[str, ...]:
        """Distinct stored values of one attribute key, sorted."""
        memo = f"attr:{key}"
        if memo not in self.cache:
            values = {a.value for e in self.graph.entities for a in e.attributes if a.key == key}
            self.cache[memo] = tuple(sorted(values))
        return self.cache[memo]  # type: ignore[no-any-return]

    def category_attribute_values(self, key: str) -> dict[str, tuple[str, ...]]:
        """Per category, the distinct stored values of one attribute key, sorted (only
        categories that store any)."""
        memo = f"attr-by-category:{key}"
        if memo not in self.cache:
            found: dict[str, set[str]] = {}
            for e in self.graph.entities:
                for a in e.attributes:
                    if a.key == key:
                        found.setdefault(e.category, set()).add(a.value)
            self.cache[memo] = {c: tuple(sorted(v)) for c, v in found.items()}
        return self.cache[memo]  # type: ignore[no-any-return]

    def attribute_pairs(self) -> tuple[tuple[str, str], ...]:
        """Distinct stored ``(key, value)`` attribute pairs, sorted."""
        if "attr-pairs" not in self.cache:
            pairs = {(a.key, a.value) for e in self.graph.entities for a in e.attributes}
            self.cache["attr-pairs"] = tuple(sorted(pairs))
        return self.cache["attr-pairs"]  # type: ignore[no-any-return]

    def colour(self, entity_id: int) -> tuple[float, float, float] | None:
        """The entity's stored mean colour (``rgb`` attribute, sRGB in [0, 1]) or ``None``."""
        values = self.by_id[entity_id].attribute_values("rgb")
        return hex_to_rgb(values[0]) if values else None

    def facing(self, entity_id: int) -> tuple[float, float] | None:
        """The horizontal unit direction the entity's front faces (its ``facing``
        attribute, see :mod:`causalsplat.objects`), or ``None`` (none stored, or one that
        is not three numbers with a horizontal part)."""
        values = self.by_id[entity_id].attribute_values("facing")
        try:
            x, y, _ = (float(v) for v in values[0].split()) if values else (0.0, 0.0, 0.0)
        except ValueError:
            return None
        norm = math.hypot(x, y)
        if not math.isfinite(norm) or norm == 0.0:
            return None
        return (x / norm, y / norm)

    def wall_facing(self, entity_id: int) -> tuple[float, float] | None:
        """The horizontal unit direction away from the walls the entity stands or hangs
        against, into the room: the front of a mirror, a window or a whiteboard, which no
        object table annotates (in a corner, between the two walls' normals). ``None``
        when the entity is structural itself, or no wall it stands alongside comes within
        :data:`WALL_CONTACT` of its footprint."""
        e = self.by_id[entity_id]
        if self.is_structural(e):
            return None
        normals: set[tuple[int, float]] = set()
        for wall in self.walls():
            sx, sy = (wall.bbox_max[k] - wall.bbox_min[k] for k in (0, 1))
            thin, along = (0, 1) if sx < sy else (1, 0)
            lo, hi = wall.bbox_min, wall.bbox_max
            if not lo[along] <= e.centroid[along] <= hi[along]:
                continue  # not alongside this wall
            gap = max(lo[thin] - e.bbox_max[thin], e.bbox_min[thin] - hi[thin], 0.0)
            side = self.centre[thin] - 0.5 * (lo[thin] + hi[thin])  # into the room
            if gap <= WALL_CONTACT and side != 0.0:
                normals.add((thin, math.copysign(1.0, side)))
        x = math.fsum(sign for axis, sign in normals if axis == 0)
        y = math.fsum(sign for axis, sign in normals if axis == 1)
        norm = math.hypot(x, y)
        return None if norm == 0.0 else (x / norm, y / norm)

    def walls(self) -> tuple[Entity, ...]:
        """Structural entities standing upright (taller than their shorter horizontal
        side): the walls, not the floor or the ceiling."""
        if "walls" not in self.cache:
            walls = []
            for e in self.graph.entities:
                size = [e.bbox_max[k] - e.bbox_min[k] for k in range(3)]
                if self.is_structural(e) and size[2] > min(size[0], size[1]):
                    walls.append(e)
            self.cache["walls"] = tuple(walls)
        return self.cache["walls"]  # type: ignore[no-any-return]

    def wall_gap(self, entity_id: int, wall_id: int) -> float:
        """The horizontal gap between an entity's footprint and a wall's (0 touching)."""
        e, w = self.by_id[entity_id], self.by_id[wall_id]
        gaps = [max(w.bbox_min[k] - e.bbox_max[k], e.bbox_min[k] - w.bbox_max[k], 0.0)
                for k in (0, 1)]  # fmt: skip
        return math.hypot(*gaps)

    def is_structural(self, entity: Entity) -> bool:
        return self.config.is_structural(entity.category)

    # -- per-Gaussian labels -------------------------------------------------------------

    def gaussian_labels(self) -> np.ndarray | None:
        """``(N,)`` int32 entity id per Gaussian (``-1``: none), or ``None`` (read once)."""
        if not self._labels_read:
            self._labels = None if self._labels_loader is None else self._labels_loader()
            self._labels_read = True
        return self._labels


def _centre(entities: tuple[Entity, ...]) -> tuple[Vec3, float]:
    """The centre of the union of the entity boxes and half its horizontal diagonal."""
    if not entities:
        return (0.0, 0.0, 0.0), 0.0
    lo = [min(e.bbox_min[k] for e in entities) for k in range(3)]
    hi = [max(e.bbox_max[k] for e in entities) for k in range(3)]
    centre = ((lo[0] + hi[0]) * 0.5, (lo[1] + hi[1]) * 0.5, (lo[2] + hi[2]) * 0.5)
    return centre, 0.5 * math.dist(lo[:2], hi[:2])
