"""Every knob of ``causalsplat build`` in one frozen dataclass, readable from a JSON file.

A config file holds any subset of the sections below; what it leaves out keeps its
default. Unknown sections or keys are refused with :class:`BuildConfigError`::

    {"max_views": 40, "units": "m", "up_axis": "z",
     "raster": {"max_contributors": 64},
     "field": {"iterations": 300, "feature_dim": 16, "weighting": "spatial"},
     "instances": {"min_cluster_size": 3, "assignment": "vote"},
     "nodes": {"bbox_quantile": 0.1},
     "edges": {"tau_v": 0.3}}
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

from causalsplat._json import JSONInputError, decode_json
from causalsplat.errors import InputFormatError
from causalsplat.field import FieldConfig
from causalsplat.field.lift import LIFT_RASTER, VIEW_STORAGES, ViewStorage
from causalsplat.graph import EdgeConfig
from causalsplat.graph.nodes import NodeConfig
from causalsplat.instances import InstanceConfig
from causalsplat.render import RasterConfig

#: Top-level options that change only speed and memory, never the result.
SPEED_ONLY: tuple[str, ...] = ("views", "memory_budget_mib", "huge_pages")


def _physical_memory() -> int:
    """Bytes of physical memory (8 GiB where the OS does not say)."""
    try:
        return int(os.sysconf("SC_PAGE_SIZE")) * int(os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):
        return 8 * 2**30


class BuildConfigError(InputFormatError):
    """A build config (file or value) is malformed; the message names the key."""


#: The config's sections, each one stage's options (a JSON object in a config file).
_SECTIONS = ("raster", "field", "instances", "nodes", "edges")


@dataclass(frozen=True, slots=True)
class BuildConfig:
    """Options of every build stage (see each section's class for its fields).

    Attributes:
        max_views: use at most this many views, evenly spaced (``None``: all).
        units: the scene's length unit, stored with the scene.
        up_axis: the vertical axis (``x``, ``y`` or ``z``) for the spatial relations.
        labeler: who names the entities: ``masks`` (the vote of the mask labels; masks
            without labels give ``object``) or ``vlm`` (an OpenAI-compatible server, set
            by ``CAUSALSPLAT_VLM_*``, looks at each entity's best mask crop).
        allow_distortion: read COLMAP cameras with lens distortion as pinhole cameras (a
            build warning) instead of refusing them; undistorting the images first
            (``colmap image_undistorter``) is the exact way.
        min_seen: the least share of Gaussians the views must see, and
        min_masked: the least share of mask pixels that must fall next to a projected
            Gaussian, for the PLY and the cameras to count as one capture
            (:mod:`causalsplat.build.coverage`); a build below either is refused. 0 turns
            a check off.
        image_scale: work at this fraction of the masks' resolution, in (0, 1]: cameras
            and masks are scaled down (:mod:`causalsplat.build.scale`), the rasterizer's
            work and the views' memory fall with its square.
        views: where the views' blending weights stay between the passes that read them:
            ``auto`` (in memory while they fit the budget, the rest memory-mapped from
            disk), ``memory``, ``disk`` or ``recompute`` (rebuilt at each use; see
            :func:`causalsplat.field.prepare_views`). Speed and memory only.
        memory_budget_mib: MiB the views' data may keep in memory under ``views="auto"``
            (``None``: a quarter of the machine's memory). The per-Gaussian arrays and one
            view in use come on top of it.
            Speed and memory only.
        huge_pages: let numpy ask for transparent huge pages for the build's large arrays
            (its default elsewhere). Off: on virtual machines the first touch of a huge
            page can cost more than the pages save (:mod:`causalsplat.build.huge_pages`).
            Speed only.
    """

    max_views: int | None = None
    units: str = "m"
    up_axis: str = "z"
    labeler: str = "masks"
    allow_distortion: bool = False
    min_seen: float = 0.05
    min_masked: float = 0.5
    image_scale: float = 1.0
    views: ViewStorage = "auto"
    memory_budget_mib: int | None = None
    huge_pages: bool = False
    raster: RasterConfig = LIFT_RASTER
    field: FieldConfig = dataclasses.field(default_factory=FieldConfig)
    instances: InstanceConfig = dataclasses.field(default_factory=InstanceConfig)
    nodes: NodeConfig = dataclasses.field(default_factory=NodeConfig)
    edges: EdgeConfig = dataclasses.field(default_factory=EdgeConfig)

    def __post_init__(self) -> None:
        if self.max_views is not None and (
            not isinstance(self.max_views, int) or self.max_views < 1
        ):
            raise BuildConfigError(f"max_views={self.max_views!r} must be a positive integer")
        if self.up_axis not in ("x", "y", "z"):
            raise BuildConfigError(f"up_axis={self.up_axis!r} must be 'x', 'y' or 'z'")
        if self.labeler not in ("masks", "vlm"):
            raise BuildConfigError(f"labeler={self.labeler!r} must be 'masks' or 'vlm'")
        if not isinstance(self.allow_distortion, bool):
            raise BuildConfigError(
                f"allow_distortion={self.allow_distortion!r} must be true or false"
            )
        for name in ("min_seen", "min_masked"):
            value = getattr(self, name)
            if (
                isinstance(value, bool)
                or not isinstance(value, int | float)
                or not (0.0 <= value <= 1.0)
            ):
                raise BuildConfigError(f"{name} must be in [0, 1], got {value!r}")
        scale = self.image_scale
        if isinstance(scale, bool) or not isinstance(scale, int | float) or not 0 < scale <= 1:
            raise BuildConfigError(f"image_scale must be in (0, 1], got {scale!r}")
        if self.views not in VIEW_STORAGES:
            raise BuildConfigError(
                f"views={self.views!r} must be one of {', '.join(map(repr, VIEW_STORAGES))}"
            )
        budget = self.memory_budget_mib
        if budget is not None and (
            isinstance(budget, bool) or not isinstance(budget, int) or budget < 0
        ):
            raise BuildConfigError(
                f"memory_budget_mib must be an integer in [0, inf) or null, got {budget!r}"
            )
        if not isinstance(self.huge_pages, bool):
            raise BuildConfigError(f"huge_pages={self.huge_pages!r} must be true or false")
        if not isinstance(self.units, str) or not self.units:
            raise BuildConfigError(f"units={self.units!r} must be a non-empty string")

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            name: getattr(self, name)
            for name in ("max_views", "units", "up_axis", "labeler", "allow_distortion",
                         "min_seen", "min_masked", "image_scale", "views", "memory_budget_mib",
                         "huge_pages")
        }  # fmt: skip
        for name in _SECTIONS:
            out[name] = _section_json(getattr(self, name))
        return out

    def result_json(self) -> dict[str, Any]:
        """:meth:`to_json` less the options that change only speed and memory (``views``,
        ``memory_budget_mib``, ``huge_pages``, ``raster.threads``, ``field.device``,
        ``field.trainer``: the two trainers take the same steps, see
        :mod:`causalsplat.field.train_torch`): what the scene's ``config_hash`` and the
        stage caches are keyed on."""
        out = self.to_json()
        for name in SPEED_ONLY:
            out.pop(name)
        out["raster"].pop("threads")
        out["field"].pop("device")
        out["field"].pop("trainer")
        return out

    def memory_budget_bytes(self) -> int:
        """The views' memory budget in bytes (``memory_budget_mib``, else a quarter of the
        RAM)."""
        if self.memory_budget_mib is not None:
            return self.memory_budget_mib * 2**20
        return _physical_memory() // 4

    @classmethod
    def from_json(cls, document: Any, *, source: str = "<config>") -> BuildConfig:
        if not isinstance(document, dict):
            raise BuildConfigError(f"{source}: a build config is a JSON object")
        top = {f.name for f in fields(cls)}
        unknown = sorted(set(document) - top)
        if unknown:
            raise BuildConfigError(f"{source}: unknown key(s) {unknown}; known: {sorted(top)}")
        kwargs: dict[str, Any] = {}
        defaults = cls()
        for key, value in document.items():
            if key in _SECTIONS:
                kwargs[key] = _section(getattr(defaults, key), value, f"{source}: {key}")
            else:
                kwargs[key] = value
        try:
            return cls(**kwargs)
        except (TypeError, ValueError) as exc:
            if isinstance(exc, BuildConfigError):
                raise
            raise BuildConfigError(f"{source}: {exc}") from exc

    @classmethod
    def from_file(cls, path: str | Path) -> BuildConfig:
        path = Path(path)
        try:
            document = decode_json(path.read_bytes())
        except (OSError, JSONInputError) as exc:
            raise BuildConfigError(f"{path}: cannot read the build config: {exc}") from exc
        return cls.from_json(document, source=str(path))


def _section(default: Any, value: Any, where: str) -> Any:
    """A section read from JSON: ``default`` (the build's own default of that section)
    with the keys ``value`` gives replaced."""
    if not isinstance(value, dict):
        raise BuildConfigError(f"{where}: expected a JSON object, got {type(value).__name__}")
    names = {f.name for f in fields(default)}
    unknown = sorted(set(value) - names)
    if unknown:
        raise BuildConfigError(f"{where}: unknown key(s) {unknown}; known: {sorted(names)}")
    try:
        return dataclasses.replace(default, **value)
    except (TypeError, ValueError) as exc:
        raise BuildConfigError(f"{where}: {exc}") from exc


def _section_json(value: Any) -> dict[str, Any]:
    return {f.name: _plain(getattr(value, f.name)) for f in dataclasses.fields(value)}


def _plain(value: Any) -> Any:
    if isinstance(value, float) and value in (float("inf"), float("-inf")):
        return str(value)
    if isinstance(value, tuple):
        return list(value)
    return value
