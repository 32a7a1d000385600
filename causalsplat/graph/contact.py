"""Support from surfaces that touch, for entities built from Gaussians.

The support rule of :mod:`causalsplat.graph.edges` reads boxes: U rests on L when U's
bottom lies within a touch tolerance of L's top (6 % of the scene's height, chosen on
ScanNet's annotated boxes) and their footprints overlap. Between the boxes of a
reconstruction that is generous: wall cabinets 15 cm above a dish rack, or a toaster on a
counter whose overhang shades a stool, pass it. A built scene knows more than boxes, it
has each entity's Gaussians, and an object that rests on another touches it.
:class:`Surfaces` holds those points and a contact radius; with them, a support pair is
kept only when at least ``max(min_points, share * n)`` of U's ``n`` points lie within the
radius of L's points. Floors are exempt: what stands on a floor touches it by the box
rule already (reconstructed floors are thick slabs), and checking them would cost a
query against the scene's largest entity.

>>> import numpy as np
>>> table = np.array([[x, y, 0.7] for x in np.linspace(0, 1, 11) for y in np.linspace(0, 1, 11)])
>>> ring = (0.4, 0.5, 0.6)
>>> cup = np.array([[x, y, z] for x in ring for y in ring for z in (0.71, 0.8)])
>>> hovering = cup + [0, 0, 0.15]
>>> s = Surfaces({1: table, 2: cup, 3: hovering}, radius=0.05)
>>> s.touching(2, 1), s.touching(3, 1)
(True, False)
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from graph_store import Relation, RelationType


@dataclass(frozen=True, slots=True, eq=False)
class Surfaces:
    """The points of each entity (its Gaussians' centres) and the contact radius.

    ``points``: entity id -> ``(n, 3)`` float array, in the entities' frame;
    ``radius``: two points closer than this touch (scene units); ``min_points`` and
    ``share``: how many of the upper entity's points must touch, at least.
    """

    points: Mapping[int, np.ndarray]
    radius: float
    min_points: int = 3
    share: float = 0.01
    _trees: dict[int, Any] = field(default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        if not (np.isfinite(self.radius) and self.radius > 0):
            raise ValueError(f"radius must be a positive finite number, got {self.radius!r}")

    def touching(self, upper: int, lower: int) -> bool:
        """Whether enough of ``upper``'s points lie within the radius of ``lower``'s."""
        up, low = self.points.get(upper), self.points.get(lower)
        if up is None or low is None or not len(up) or not len(low):
            return True  # nothing to check against: the box rule stands
        tree = self._trees.get(lower)
        if tree is None:
            from scipy.spatial import cKDTree

            tree = self._trees[lower] = cKDTree(np.asarray(low, dtype=np.float64))
        dist, _ = tree.query(np.asarray(up, dtype=np.float64), k=1,
                             distance_upper_bound=self.radius)  # fmt: skip
        need = max(self.min_points, int(np.ceil(self.share * len(up))))
        return int(np.isfinite(dist).sum()) >= min(need, len(up))


def drop_without_contact(
    relations: Sequence[Relation], surfaces: Surfaces, floors: Iterable[int] = ()
) -> list[Relation]:
    """``relations`` without the support pairs (both directions) whose entities do not
    touch; pairs on a floor are kept."""
    exempt = set(floors)
    apart: set[tuple[int, int]] = set()
    for r in relations:
        supported = r.type is RelationType.SUPPORTED_BY and r.dst not in exempt
        if supported and not surfaces.touching(r.src, r.dst):
            apart.add((r.src, r.dst))
    if not apart:
        return list(relations)
    return [
        r
        for r in relations
        if not (r.type is RelationType.SUPPORTED_BY and (r.src, r.dst) in apart)
        and not (r.type is RelationType.SUPPORTS and (r.dst, r.src) in apart)
    ]
