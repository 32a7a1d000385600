"""The thresholds of the edge rules (DESIGN §2, §7) in one frozen dataclass.

Every number the rules use is a field here, never a literal in the rule code. Lengths are
never absolute: each threshold is a ratio, or a fraction of a size measured on the scene
itself (an entity's box, the scene's extent), so a scene gives the same relations in
millimetres, metres or kilometres. :mod:`causalsplat.graph.edges` states the rules.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Any

from causalsplat._checks import Allowed, Interval, check_fields
from causalsplat.graph.errors import EdgeConfigError


@dataclass(frozen=True, slots=True)
class EdgeConfig:
    """Options of :func:`~causalsplat.graph.edges.build_relations`.

    Attributes:
        tau_v: vertical rule, ``|Δz| / d > tau_v`` (centroids; the paper's τ_v = 0.3).
        horizontal_size_factor: ``a`` in the horizontal tolerance
            ``D = min(max(a·|b̄_xy|, lo·S_xy), hi·S_xy)`` (the paper's 0.55).
        horizontal_min_fraction: ``lo`` in ``D``, a fraction of ``S_xy`` (the paper's 0.08).
        horizontal_max_fraction: ``hi`` in ``D``, a fraction of ``S_xy`` (the paper's 0.35).
        touch_fraction: support touch tolerance as a fraction of the scene's vertical
            extent ``S_z`` (the union of all boxes along the up axis). The paper gives no
            value; 0.06 (about 15 cm in a 2.5 m room) was chosen on the Sr3D *train*
            support rows of ScanNet (see ``docs/benchmarks.md``).
        touch_height_factor: the touch tolerance of a pair is also at most this many times
            the taller box of the pair (``tol = min(touch_fraction·S_z,
            touch_height_factor·max(h_upper, h_lower))``); ``math.inf`` disables the clamp.
        reduce_support: when True (default), an object does not rest on what its other
            supporters rest on (a cup on a book on a table rests on the book only); False
            keeps every pair that passes the touch rule. See
            ``causalsplat/graph/_support_reduction.py``.
        support_overlap: support needs the top-view overlap of the two boxes to cover at
            least this fraction of the upper entity's footprint (Sr3D's 0.3); in ``(0, 1]``.
        contain_overlap: containment needs the box overlap to cover at least this
            fraction of the inner entity's volume (0.8); in ``(0, 1]``.
        near_factor: ``near`` when the centroid distance is below this many times the sum
            of the two footprint half-diagonals (1.5).
        floor_categories: categories (matched case-insensitively, surrounding blanks
            ignored) of floors: they support what stands on them and are never supported.
        wall_categories: categories of walls: they support nothing and are never supported.
        ceiling_categories: categories of ceilings: as walls.
        relate_structural: when False (default), floors, walls and ceilings take no part in
            above/below/near/next_to; when True they do (support and containment rules for
            them are as above either way).
        contact_scales: in a scene built from Gaussians, a support pair off the floor needs
            the two entities' Gaussians to touch: centres within this many median
            Gaussian sizes (the largest axis) of one another
            (:mod:`causalsplat.graph.contact`); 0 keeps the box rule alone. Object tables
            (no Gaussians) use the box rule.
    """

    tau_v: float = 0.3
    horizontal_size_factor: float = 0.55
    horizontal_min_fraction: float = 0.08
    horizontal_max_fraction: float = 0.35
    touch_fraction: float = 0.06
    touch_height_factor: float = math.inf
    reduce_support: bool = True
    support_overlap: float = 0.3
    contain_overlap: float = 0.8
    near_factor: float = 1.5
    floor_categories: tuple[str, ...] = ("floor",)
    wall_categories: tuple[str, ...] = ("wall",)
    ceiling_categories: tuple[str, ...] = ("ceiling",)
    relate_structural: bool = False
    contact_scales: float = 3.0

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name.endswith("_categories"):
                object.__setattr__(self, f.name, _categories(f.name, value))
            elif f.name in ("relate_structural", "reduce_support"):
                if not isinstance(value, bool):
                    raise EdgeConfigError(f"EdgeConfig.{f.name} must be a bool, got {value!r}")
            else:
                _number(f.name, value)
        values = {f.name: getattr(self, f.name) for f in fields(self)}
        check_fields("EdgeConfig", values, _ALLOWED, EdgeConfigError)
        check_fields("EdgeConfig", values,
                     {"horizontal_max_fraction": Interval(self.horizontal_min_fraction)},
                     EdgeConfigError)  # fmt: skip
        groups = (self.floor_categories, self.wall_categories, self.ceiling_categories)
        seen: set[str] = set()
        for group in groups:
            for name in group:
                if name in seen:
                    raise EdgeConfigError(
                        f"EdgeConfig: category {name!r} is in two structural lists"
                    )
                seen.add(name)

    @classmethod
    def tuned_for_scannet(cls) -> EdgeConfig:
        """The defaults with ``horizontal_size_factor = 0.8`` instead of the paper's 0.55.

        Chosen on the Sr3D *train* rows of ScanNet, where the paper's tolerance misses
        about a fifth of the labelled above/below pairs (large objects offset
        horizontally: wall cabinets over a counter, a picture over a bed); see
        ``docs/benchmarks.md`` for the test-split figures of both.
        """
        return cls(horizontal_size_factor=0.8)

    def to_dict(self) -> dict[str, Any]:
        """The config as plain JSON-compatible values (``inf`` as the string ``"inf"``)."""
        out: dict[str, Any] = {}
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, tuple):
                value = list(value)
            elif isinstance(value, float) and math.isinf(value):
                value = "inf"
            out[f.name] = value
        return out


_ALLOWED: dict[str, Allowed] = {
    "tau_v": Interval(0, 1, high_open=True),
    "horizontal_size_factor": Interval(0),
    "horizontal_min_fraction": Interval(0),
    "touch_fraction": Interval(0),
    "touch_height_factor": Interval(0, infinite=True),
    "support_overlap": Interval(0, 1, low_open=True),
    "contain_overlap": Interval(0, 1, low_open=True),
    "near_factor": Interval(0),
    "contact_scales": Interval(0),
}


def _number(name: str, value: object) -> None:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise EdgeConfigError(f"EdgeConfig.{name} must be a number, got {value!r}")
    if math.isnan(value) or (math.isinf(value) and name != "touch_height_factor"):
        raise EdgeConfigError(f"EdgeConfig.{name} must be finite, got {value!r}")


def _categories(name: str, value: object) -> tuple[str, ...]:
    if isinstance(value, str) or not isinstance(value, tuple | list | frozenset | set):
        raise EdgeConfigError(f"EdgeConfig.{name} must be a tuple of strings, got {value!r}")
    out: list[str] = []
    for item in value:
        if not isinstance(item, str) or not item.strip():
            raise EdgeConfigError(f"EdgeConfig.{name} holds {item!r}, not a non-empty string")
        key = item.strip().lower()
        if key not in out:
            out.append(key)
    return tuple(sorted(out))
