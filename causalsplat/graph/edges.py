"""Scene-graph edges: scale-adaptive spatial relations between entities (DESIGN §7).

:func:`build_relations` finds every relation of the rules below with KD-tree candidate
pairs and vectorised rules; :func:`build_relations_bruteforce` is the reference: the same
rules written as a plain loop over every pair. Both return the same relations with the
same evidence numbers (the arithmetic is done in the same order: bit-identical).
Thresholds live in :class:`~causalsplat.graph.config.EdgeConfig`; defaults in brackets.

Frame. Entities carry a centroid and an axis-aligned box (``bbox_min``/``bbox_max``) in
scene units; ``up_axis`` names the vertical axis (``z`` by default), the two others are
"horizontal" and the "footprint" of a box is its extent on them. Per scene:
``S_xy`` = the diagonal of the horizontal extent of all entity *centroids*
(``sqrt((max cx - min cx)² + (max cy - min cy)²)``, floors and walls included);
``S_z`` = the vertical extent of the union of all *boxes*.

Rules, for an ordered pair (A, B); every relation is emitted in both directions (A above
B and B below A; near both ways), so a query can start from either end:

- **above / below** (the paper's rule): with ``d`` the centroid distance, ``h`` the
  horizontal centroid distance and ``Δz = z_A - z_B``: ``|Δz| / d > tau_v`` [0.3] and
  ``h <= D``, ``D = min(max(a·sqrt(b̄x² + b̄y²), lo·S_xy), hi·S_xy)`` [a = 0.55,
  lo = 0.08, hi = 0.35], where ``b̄ = (size_A + size_B) / 2`` is the mean of the two boxes'
  horizontal extents. A is above B when ``Δz > 0``. ``d = 0`` (coincident centroids) gives a
  vertical ratio of 0: no relation. ``h <= D`` (not ``<``) so that a stack whose centroids
  lie on one vertical line (``S_xy = 0``, ``D = 0``) is still ordered. Evidence:
  ``distance``, ``horizontal_distance``, ``vertical_ratio``, ``horizontal_tolerance`` (D),
  ``height_difference`` (``z_src - z_dst``). The paper's rule caps ``D`` at
  ``0.35·S_xy``: in a scene of two entities that are not vertically aligned, neither is
  above the other.
- **supported_by / supports**: U is supported by L when U's box is the higher one (its
  mid-height above L's), ``|gap| <= tol`` with ``gap = bottom_U - top_L`` (negative when
  the boxes interpenetrate, as reconstructed boxes do), and the top-view overlap of the
  two boxes covers at least ``support_overlap`` [0.3] of U's footprint (Sr3D's rule).
  ``tol = min(touch_fraction·S_z, touch_height_factor·max(h_U, h_L))`` [0.06·S_z, no
  height clamp; the paper gives no value, 0.06 was chosen on Sr3D train rows]: a
  fraction of the scene's vertical extent, optionally clamped by the taller box of the
  pair. Floors support what stands on them and are never supported:
  for a floor the touch test is that U's bottom lies within the floor box's vertical
  extent widened by ``tol`` on both sides (and U's box need not be the higher one), since
  reconstructed floor boxes are thick (ScanNet scene0000_00: the floor spans z = -0.06 to
  0.29 m while the furniture stands at z ≈ 0). Walls and ceilings support nothing and are
  never supported; with no floor entity nothing is floor-supported. Of the supporters
  that pass, an entity drops those its other supporters rest on (``reduce_support``
  [True]): a cup on a book on a table rests on the book only, a board across two stools
  on both. Given the entities' points (a built scene, ``surfaces=``), a pair off the
  floor is kept only when the points touch (:mod:`causalsplat.graph.contact`), before
  that reduction. Evidence: ``gap``,
  ``touch_tolerance``, ``overlap`` (fraction of U's footprint), ``distance``.
- **inside / contains**: A is inside B when A's box volume is strictly smaller and the
  box overlap covers at least ``contain_overlap`` [0.8] of A's volume; never with a
  floor, wall or ceiling. Evidence: ``overlap`` (fraction of A's volume),
  ``volume_ratio`` (``V_A / V_B``), ``distance``.
- **near** (symmetric): centroid distance ``< near_factor·(r_A + r_B)`` [1.5], ``r`` the
  half-diagonal of a footprint. **next_to**: near, and the two boxes' vertical extents
  overlap by a positive length. Evidence: ``distance``, ``near_threshold``, and for
  next_to ``vertical_overlap``.
- Floors, walls and ceilings (``*_categories``) take no part in above/below/near/next_to
  unless ``relate_structural`` is set.

Overlap fractions are per-axis products (``∏ overlap_k / extent_k``); an axis where the
inner box has zero extent counts 1 when it touches the other box (closed interval) and
0 otherwise, so zero-size boxes give finite evidence. Every evidence number is finite.

Units: every threshold is a ratio or a fraction of a length measured on the scene, so a
scene scaled to millimetres or kilometres gives the same relations (evidence lengths
scale with it); an offset of all coordinates gives the same relations. Coordinates
beyond ``1e100`` scene units raise :class:`~causalsplat.graph.errors.EdgeInputError`.

Candidates (never all pairs). Each rule has a reach bounded by the larger entity of a
pair, and each entity queries a KD-tree with its own reach, keeping neighbours no larger
than itself: ``near`` within ``2·near_factor·r`` (3D tree on centroids); ``above`` within
``min(max(a·2r, lo·S_xy), hi·S_xy)`` (2D tree on horizontal centroids; ``|b̄| <= 2·max r``);
support and containment within Chebyshev distance ``2·m + tol`` of the box centres
(``m`` the largest half extent: touching or overlapping boxes). Only relation types with
candidate pairs are evaluated.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Literal

import numpy as np

from causalsplat.graph._edge_candidates import all_pairs, box_pairs, near_pairs, vertical_pairs
from causalsplat.graph._edge_rules import (
    EdgeBatch,
    containment,
    evaluate_pairs,
    proximity,
    support,
    vertical,
)
from causalsplat.graph._edge_scene import FLOOR, EdgeScene, prepare_scene
from causalsplat.graph._edges_reference import reference_relations
from causalsplat.graph._support_reduction import reduce_supporters
from causalsplat.graph.config import EdgeConfig
from causalsplat.graph.contact import Surfaces, drop_without_contact
from graph_store import Entity, Relation, RelationType

Candidates = Literal["kdtree", "all"]


def build_relations(
    entities: Sequence[Entity],
    config: EdgeConfig | None = None,
    *,
    up_axis: str = "z",
    candidates: Candidates = "kdtree",
    surfaces: Surfaces | None = None,
) -> tuple[Relation, ...]:
    """The stored relations between ``entities`` (sorted by src, type, dst).

    ``candidates="kdtree"`` (default) evaluates the rules on KD-tree candidate pairs;
    ``"all"`` evaluates the same vectorised rules on every pair (a baseline for
    benchmarks). ``surfaces`` (a built scene's entity points): a support pair off the
    floor is kept only where the two entities' points touch
    (:mod:`causalsplat.graph.contact`), before the supporters are reduced. Raises
    :class:`~causalsplat.graph.errors.EdgeInputError` for bad input.
    """
    config = config or EdgeConfig()
    scene = prepare_scene(entities, config, up_axis)
    if candidates == "all":
        batches = [b for i, j in all_pairs(scene.n) for b in evaluate_pairs(scene, config, i, j)]
    elif candidates == "kdtree":
        batches = _kdtree_batches(scene, config)
    else:
        from causalsplat.graph.errors import EdgeInputError

        raise EdgeInputError(f"candidates must be 'kdtree' or 'all', got {candidates!r}")
    return tuple(reduce_supporters(_touching(scene, _relations(scene, batches), surfaces), config))


def build_relations_bruteforce(
    entities: Sequence[Entity],
    config: EdgeConfig | None = None,
    *,
    up_axis: str = "z",
    surfaces: Surfaces | None = None,
) -> tuple[Relation, ...]:
    """The same relations by a scalar loop over every pair (the slow, plain reference)."""
    config = config or EdgeConfig()
    scene = prepare_scene(entities, config, up_axis)
    found = reference_relations(scene, config)
    ids = scene.ids.tolist()
    relations = [Relation(ids[s], ids[d], t, tuple(ev.items())) for (s, t, d), ev in found.items()]
    relations.sort(key=_order)
    return tuple(reduce_supporters(_touching(scene, relations, surfaces), config))


def _touching(
    scene: EdgeScene, relations: Sequence[Relation], surfaces: Surfaces | None
) -> Sequence[Relation]:
    if surfaces is None:
        return relations
    floors = scene.ids[scene.kind == FLOOR].tolist()
    return drop_without_contact(relations, surfaces, floors)


def _kdtree_batches(scene: EdgeScene, config: EdgeConfig) -> list[EdgeBatch]:
    batches: list[EdgeBatch] = []
    i, j = near_pairs(scene, config)
    if i.size:
        batches += proximity(scene, config, i, j)
    i, j = vertical_pairs(scene, config)
    if i.size:
        batches += vertical(scene, config, i, j)
    i, j = box_pairs(scene, config)
    if i.size:
        batches += support(scene, config, i, j)
        batches += containment(scene, config, i, j)
    return batches


def _relations(scene: EdgeScene, batches: list[EdgeBatch]) -> tuple[Relation, ...]:
    ids = scene.ids.tolist()
    out: list[Relation] = []
    for batch in batches:
        if not len(batch):
            continue
        names = [name for name, _ in batch.evidence]
        columns = [np.asarray(values).tolist() for _, values in batch.evidence]
        pairs = zip(batch.src.tolist(), batch.dst.tolist(), strict=True)
        for (s, d), row in zip(pairs, zip(*columns, strict=True), strict=True):
            evidence = tuple(zip(names, row, strict=True))
            out.append(Relation(ids[s], ids[d], batch.type, evidence))
    out.sort(key=_order)
    return tuple(out)


def _order(r: Relation) -> tuple[int, str, int]:
    return (r.src, r.type.value, r.dst)


__all__ = ["EdgeConfig", "RelationType", "build_relations", "build_relations_bruteforce"]
