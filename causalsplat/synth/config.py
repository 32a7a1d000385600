"""Every parameter of a synthetic scene, in one frozen :class:`SynthConfig`, and the presets."""

from __future__ import annotations

from dataclasses import dataclass, field, fields, replace
from typing import Any

from causalsplat._checks import Interval, check_fields
from causalsplat.errors import CausalSplatError
from causalsplat.masks.noise import MAX_STRENGTH, NoiseConfig

#: Names of the size presets, smallest first.
SIZES: tuple[str, ...] = ("tiny", "small", "medium")


class InvalidSynthConfigError(CausalSplatError, ValueError):
    """A synthetic-scene size or parameter is unknown or out of range."""


@dataclass(frozen=True, slots=True)
class SynthConfig:
    """Parameters of one procedural room (units: metres, pixels, degrees).

    Attributes:
        size: preset name (``tiny``, ``small``, ``medium``) or ``custom``.
        seed: the one seed everything is drawn from (same seed, same bytes).
        room_size_m: interior floor size (x, y); walls stand outside it.
        wall_height_m: wall height.
        n_furniture: furniture pieces to place (the motifs' pieces count).
        n_small: small objects to place on furniture or on other small objects.
        n_tray_bridges: extra two-supporter motifs "a tray spanning two tables" (a board
            across two stools is always present).
        n_gaussians: Gaussian budget of the whole scene (met to within rounding).
        min_gaussians_per_object: floor on the Gaussians of one entity.
        density_weights: relative Gaussians per m² for structure, furniture, small objects.
        gaussian_scale: Gaussian standard deviation as a fraction of the sample spacing.
        normal_scale: standard deviation along the face normal as a fraction of the one
            in the face's plane (trained 3DGS flattens Gaussians onto surfaces; 1 makes
            them spheres).
        color_noise: standard deviation of per-Gaussian colour noise (RGB in [0, 1]).
        opacity: opacity of every Gaussian.
        n_views, width, height, fov_y_deg: cameras (pinhole, square pixels).
        noise_strength: strength of the SAM-like noise on the written masks (0 = exact GT).
        noise: per-effect rates of the noise model at strength 1.
        points_per_object: point subsample per object written to ``objects.json``.
        max_queries_per_type: cap on generated queries per reasoning type.
    """

    size: str
    seed: int
    room_size_m: tuple[float, float]
    n_furniture: int
    n_small: int
    n_gaussians: int
    n_views: int
    width: int
    height: int
    n_tray_bridges: int = 0
    wall_height_m: float = 2.5
    min_gaussians_per_object: int = 40
    density_weights: tuple[float, float, float] = (1.0, 3.0, 12.0)
    gaussian_scale: float = 0.75
    normal_scale: float = 0.2
    color_noise: float = 0.03
    opacity: float = 0.95
    fov_y_deg: float = 60.0
    noise_strength: float = 1.0
    noise: NoiseConfig = field(default_factory=NoiseConfig)
    points_per_object: int = 64
    max_queries_per_type: int = 6

    def __post_init__(self) -> None:
        positive = ("n_furniture", "n_gaussians", "n_views", "width", "height")
        for name in positive:
            if int(getattr(self, name)) <= 0:
                raise InvalidSynthConfigError(f"SynthConfig.{name}={getattr(self, name)} <= 0")
        if self.n_small < 0 or self.n_tray_bridges < 0:
            raise InvalidSynthConfigError("SynthConfig: n_small and n_tray_bridges must be >= 0")
        if min(self.room_size_m) < 2.5 or self.wall_height_m < 2.0:
            raise InvalidSynthConfigError(
                f"SynthConfig: room {self.room_size_m} x {self.wall_height_m} m is too small "
                "(at least 2.5 m wide and 2 m high)"
            )
        check_fields(
            "SynthConfig",
            {"noise_strength": self.noise_strength, "seed": self.seed},
            {"noise_strength": Interval(0, MAX_STRENGTH), "seed": Interval(0, integer=True)},
            InvalidSynthConfigError,
        )
        if not 10 <= self.fov_y_deg <= 120:
            raise InvalidSynthConfigError(f"SynthConfig.fov_y_deg={self.fov_y_deg}")
        if not 0 < self.normal_scale <= 1:
            raise InvalidSynthConfigError(f"SynthConfig.normal_scale={self.normal_scale}")
        if not 0 < self.opacity < 1:
            raise InvalidSynthConfigError(f"SynthConfig.opacity={self.opacity}")

    @classmethod
    def preset(cls, size: str, *, seed: int = 0, **overrides: Any) -> SynthConfig:
        """The ``tiny`` / ``small`` / ``medium`` preset, with ``overrides`` applied."""
        if size not in _PRESETS:
            raise InvalidSynthConfigError(
                f"unknown size {size!r}; expected one of: {', '.join(SIZES)}"
            )
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(overrides) - known)
        if unknown:
            raise InvalidSynthConfigError(f"unknown SynthConfig field(s): {', '.join(unknown)}")
        return replace(_PRESETS[size], seed=int(seed), **overrides)

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready description (written to ``gt/scene.json``)."""
        out: dict[str, Any] = {}
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, NoiseConfig):
                value = {g.name: getattr(value, g.name) for g in fields(value)}
            out[f.name] = list(value) if isinstance(value, tuple) else value
        if isinstance(out["noise"], dict):
            out["noise"]["fragment_radius"] = list(out["noise"]["fragment_radius"])
        return out


_PRESETS: dict[str, SynthConfig] = {
    "tiny": SynthConfig(
        size="tiny",
        seed=0,
        room_size_m=(4.0, 3.5),
        n_furniture=4,
        n_small=4,
        n_gaussians=6_000,
        n_views=12,
        width=128,
        height=96,
        min_gaussians_per_object=60,
        max_queries_per_type=4,
    ),
    "small": SynthConfig(
        size="small",
        seed=0,
        room_size_m=(6.0, 5.0),
        n_furniture=11,
        n_small=14,
        n_tray_bridges=1,
        n_gaussians=30_000,
        n_views=24,
        width=160,
        height=120,
        max_queries_per_type=8,
    ),
    "medium": SynthConfig(
        size="medium",
        seed=0,
        room_size_m=(9.0, 7.5),
        n_furniture=26,
        n_small=34,
        n_tray_bridges=1,
        n_gaussians=100_000,
        n_views=48,
        width=240,
        height=180,
        max_queries_per_type=12,
    ),
}
