"""The knobs of the 3D instance assignment (HDBSCAN over mask features, then Gaussians)."""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass
from typing import Any, Literal

from causalsplat._checks import Allowed, Interval, check_fields
from causalsplat.errors import CausalSplatError


class InstanceConfigError(CausalSplatError, ValueError):
    """An :class:`InstanceConfig` value is out of range; the message names the field."""


@dataclass(frozen=True, slots=True)
class InstanceConfig:
    """Options of :func:`~causalsplat.instances.assign_instances`.

    Attributes:
        min_cluster_size: HDBSCAN's smallest cluster, in masks (an object must be seen
            as a mask in at least this many views to become an entity).
        min_samples: HDBSCAN's density neighbourhood (``None``: ``min_cluster_size``).
        selection: HDBSCAN's cluster selection, ``eom`` (excess of mass) or ``leaf``.
        selection_epsilon: HDBSCAN's ``cluster_selection_epsilon`` (distance between unit
            vectors; clusters closer than this are merged). 0.4 (cosine 0.92): without
            it, the masks of one large object seen from different sides form several
            clusters (measured on the synthetic scenes, see docs/benchmarks.md).
        assignment: how a Gaussian picks its entity. ``feature`` (the method's rule):
            ``argmax_k f·C_k``, accepted when the cosine reaches ``min_similarity``.
            ``vote`` (default): one vote per view in which the Gaussian is drawn inside
            clustered masks, split by its blending weight among their clusters,
            weighted by the feature agreement ``max(0, f·C_k) ** vote_feature_power``
            and normalised to shares; accepted when the winner's share reaches
            ``min_vote_share``. The vote does not suffer from Adam moving barely visible
            Gaussians as fast as visible ones, nor lets one view's merged mask outvote
            the others; the build benchmark measures both rules.
        min_similarity: the cosine a ``feature`` assignment needs; below it the Gaussian
            stays unassigned (-1).
        vote_feature_power: exponent of the feature agreement in the ``vote`` rule; 0
            counts the views' votes alone.
        min_vote_share: the share a ``vote`` assignment needs; below it the Gaussian
            stays unassigned (-1).
        min_gaussians: clusters that win fewer Gaussians are dropped (no entity).
        min_evidence: a Gaussian whose evidence (its summed weight inside all masks,
            ``sum_m sum_x W_m(x) w(x, g)``) is below this fraction of the scene's median
            is weakly seen, mostly through an occluder whose masks it then votes for (the
            floor under a table top); such Gaussians, and active ones left unassigned,
            take their entity from the surface graph
            (:mod:`causalsplat.instances.propagate`). 0 relabels only the unassigned.
        propagate_sigmas: edges of the surface graph are at most this many median
            Gaussian scales long; 0 turns the propagation off (weakly seen Gaussians keep
            their vote, unseen ones stay unassigned).
        propagate_neighbors: neighbours per Gaussian in the surface graph.
        propagate_coplanar: weigh the graph's edges by how well the two Gaussians lie in
            one plane: a flat Gaussian's own, or the plane its neighbours' centres make
            (spheres, as a mesh's vertices become); ``False`` uses distance alone.
        propagate_feature_power: weigh the graph's edges by the agreement of the two
            Gaussians' features, ``max(0.1, f_i·f_j) ** p``; 0 turns it off. Set on the
            dev scenes: 1 raised scene0000_00's PQ from 0.678 to 0.701 (exact masks) and
            from 0.610 to 0.632 (default noise), the barely seen sides of a microwave, a
            toaster oven and a TV no longer going to the cabinet or fridge they touch;
            the synthetic rooms moved by -0.006 to +0.002 (0.5 gave 0.695 / 0.629).
        propagate_colour_sigma: weigh the graph's edges by how alike the two Gaussians'
            base colours (SH DC) are, ``exp(-(dE / sigma)**2 / 2)``, ``dE`` their CIELAB
            distance: two touching surfaces of different colours (a cabinet's hidden back
            and the wall it stands against) are likely two objects. 0 turns it off; a scene
            without colour (every Gaussian alike) is unchanged. Set on the dev scenes (PQ
            at 0 / 20): synthetic small seeds 0-2 0.880 / 0.895, 0.873 / 0.916,
            0.873 / 0.897, scene0000_00 0.789 / 0.793 (exact masks) and 0.770 / 0.772
            (default noise), the same copied 8 times 0.676 both; 10 cut scene0000_00's
            default-noise build to 0.742, 40 gave the synthetic rooms half the gain.
        vote_smoothing: before step 4, the well-seen Gaussians' votes are smoothed along
            the surface graph (:mod:`causalsplat.instances.smooth`): a Gaussian's own vote
            weighs ``min(c, 3) / vote_smoothing`` of its edges, ``c`` its evidence over
            the median, so a patch of wrong votes (a fragment or merged mask, a mask
            border) goes to the surface around it; 0 turns it off (``vote`` assignment
            only). Set on the dev scenes: 10 raised PQ from 0.793 to 0.797 on
            scene0000_00 (exact masks), 0.742 to 0.756 (default noise), 0.852 / 0.853 to
            0.879 / 0.873 on synthetic small seeds 0 / 1 and 0.836 to 0.857 on medium
            seed 0; 33 (smoother) gave 0.793 / 0.746 / 0.887 / 0.881 / 0.863.
        merge_overlap: multi-view consensus (:mod:`causalsplat.instances.consensus`):
            two clusters are one object when at least this share of the smaller one's
            votes falls on Gaussians the other claims as much, and their centres agree
            to ``merge_cosine``; 1 turns merging off. Set on the dev scenes (synthetic
            small seeds 0-4, scene0000_00 from exact and from noisy masks): 0.4 / 0.4
            raised their mean panoptic quality from 0.736 to 0.783; overlap alone
            merged neighbours (0.5: PQ 0.43 on scene0000_00), since a small object's
            Gaussians are drawn inside its support's masks too.
        merge_cosine: the cosine of the two clusters' centres merging needs (clusters of
            different objects that overlap stay below 0.25 on scene0000_00, those of one
            object seen from two sides reach 0.48-0.70).
        merge_structures: mask labels (matched case-insensitively) of structures a room
            has one of: the clusters that most of their masks label so are one entity
            (:mod:`causalsplat.instances.structures`; no view shows a whole floor, and
            far-apart parts of it share no Gaussian for the consensus to see). On
            scene0000_00 the floor and the ceiling fell into 3 and 2 clusters: joining
            them raised PQ from 0.647 to 0.678 (exact masks) and 0.576 to 0.610
            (default noise). Empty turns it off (a capture of several rooms whose
            ceilings should stay apart); unlabelled masks are never joined this way.
            Walls are left out: a room has several.
        split_gap: an entity whose Gaussians fall into pieces more than this many median
            Gaussian sizes (the largest axis) apart is split where its masks say
            (:mod:`causalsplat.instances.pieces`; pieces of at least a fifth of it and
            ``min_gaussians``); the floor and the ceiling never are. 0 turns it off.
            Set on the dev scenes: 20 (about 0.5 m on scene0000_00) separated a window
            from a box 2 m away (default noise: PQ 0.632 -> 0.653) and left the exact-mask
            build and the synthetic dev rooms as they were; 10 and less also cut the
            ceiling's far parts apart (the ceiling is now kept whole).
    """

    min_cluster_size: int = 3
    min_samples: int | None = 1
    selection: Literal["eom", "leaf"] = "eom"
    selection_epsilon: float = 0.4
    assignment: Literal["vote", "feature"] = "vote"
    min_similarity: float = 0.5
    vote_feature_power: float = 1.0
    min_vote_share: float = 0.25
    min_gaussians: int = 8
    min_evidence: float = 0.5
    propagate_sigmas: float = 3.0
    propagate_neighbors: int = 16
    propagate_coplanar: bool = True
    propagate_feature_power: float = 1.0
    propagate_colour_sigma: float = 20.0
    vote_smoothing: float = 10.0
    merge_overlap: float = 0.4
    merge_cosine: float = 0.4
    merge_structures: tuple[str, ...] = ("floor", "ceiling")
    split_gap: float = 20.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "merge_structures", _names(self.merge_structures))
        allowed = dict(_ALLOWED)
        if self.min_samples is None:
            del allowed["min_samples"]
        check_fields("InstanceConfig", asdict(self), allowed, InstanceConfigError)
        if not isinstance(self.propagate_coplanar, bool):
            raise InstanceConfigError(
                f"InstanceConfig.propagate_coplanar must be a bool, got {self.propagate_coplanar!r}"
            )

    def to_json(self) -> dict[str, Any]:
        return asdict(self)

    def digest(self) -> str:
        return hashlib.sha256(json.dumps(self.to_json(), sort_keys=True).encode()).hexdigest()


def _names(value: object) -> tuple[str, ...]:
    """``merge_structures`` as a sorted tuple of stripped, lower-cased names."""
    if isinstance(value, str) or not isinstance(value, tuple | list):
        raise InstanceConfigError(
            f"InstanceConfig.merge_structures must be a list of labels, got {value!r}"
        )
    out: set[str] = set()
    for item in value:
        if not isinstance(item, str) or not item.strip():
            raise InstanceConfigError(
                f"InstanceConfig.merge_structures holds {item!r}, not a non-empty label"
            )
        out.add(item.strip().lower())
    return tuple(sorted(out))


_ALLOWED: dict[str, Allowed] = {
    "min_cluster_size": Interval(2, integer=True),
    "min_samples": Interval(1, integer=True),
    "selection": ("eom", "leaf"),
    "selection_epsilon": Interval(0),
    "assignment": ("vote", "feature"),
    "min_similarity": Interval(-1, 1),
    "vote_feature_power": Interval(0),
    "min_vote_share": Interval(0, 1),
    "min_gaussians": Interval(1, integer=True),
    "min_evidence": Interval(0),
    "propagate_sigmas": Interval(0),
    "propagate_neighbors": Interval(1, integer=True),
    "propagate_feature_power": Interval(0),
    "propagate_colour_sigma": Interval(0),
    "vote_smoothing": Interval(0),
    "merge_overlap": Interval(0, 1),
    "merge_cosine": Interval(-1, 1),
    "split_gap": Interval(0),
}
