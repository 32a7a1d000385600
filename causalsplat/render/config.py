"""The rasterizer's knobs in one frozen dataclass (defaults as in the INRIA 3DGS rasterizer)."""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Literal

from causalsplat._checks import Allowed, Interval, check_fields
from causalsplat.render.errors import RenderError

#: Values of :attr:`RasterConfig.backend`.
BACKENDS = ("auto", "numba", "numpy")


@dataclass(frozen=True, slots=True)
class RasterConfig:
    """Options of the EWA splatting rasterizer (the reference and the fast path share them).

    Attributes:
        low_pass: px², added to the diagonal of every projected 2D covariance (the "0.3 px"
            screen-space low-pass / dilation of 3DGS; opacity is not compensated).
        near: scene units; Gaussians whose mean has camera depth ``z < near`` are culled.
        far: scene units; Gaussians with ``z > far`` are culled.
        alpha_max: per-Gaussian alpha is clamped to at most this value (0.99).
        alpha_min: a Gaussian whose alpha at a pixel is below this (1/255) is skipped there.
        transmittance_min: front-to-back compositing of a pixel stops *before* the Gaussian
            that would bring the transmittance below this value (1e-4), as in 3DGS.
        max_contributors: if set, a pixel keeps at most this many contributing Gaussians
            (the nearest ones) and stops there; ``None`` keeps all until ``transmittance_min``.
        jacobian_margin: the projection Jacobian is evaluated with ``x/z`` and ``y/z``
            clamped to the field of view widened by this fraction of the half-angle tangent
            on each side (0.3, as 3DGS), which keeps off-screen Gaussians from exploding.
        tile_size: px, side of the square screen tiles the numpy path bins the Gaussians
            to (performance only; the numba kernel composites 128 x 8 px tiles row by row).
        chunk: Gaussians per vectorised step inside a tile of the numpy path (performance
            only).
        backend: who builds the contributors: ``numba`` (the compiled kernel of
            :mod:`causalsplat.render._kernel`, parallel over tiles), ``numpy`` (the
            vectorised reference path of :mod:`causalsplat.render._contributors`) or
            ``auto`` (numba when it imports, else numpy). Both give the same pixels,
            Gaussians and order; weights agree to float32 rounding.
        threads: threads of the numba kernel; ``None`` uses every core this process may run
            on (``os.sched_getaffinity``), at most numba's ``NUMBA_NUM_THREADS``. The output
            does not depend on it (performance only, not part of the cache key).
    """

    low_pass: float = 0.3
    near: float = 0.01
    far: float = 1e10
    alpha_max: float = 0.99
    alpha_min: float = 1.0 / 255.0
    transmittance_min: float = 1e-4
    max_contributors: int | None = None
    jacobian_margin: float = 0.3
    tile_size: int = 16
    chunk: int = 256
    backend: Literal["auto", "numba", "numpy"] = "auto"
    threads: int | None = None

    def __post_init__(self) -> None:
        values = {f.name: getattr(self, f.name) for f in fields(self)}
        allowed: dict[str, Allowed] = {
            "low_pass": Interval(0),
            "near": Interval(0, low_open=True),
            "far": Interval(self.near if self.near in Interval() else None, low_open=True),
            "alpha_max": Interval(0, 1, low_open=True, high_open=True),
            "alpha_min": Interval(
                0, self.alpha_max if self.alpha_max in Interval() else None,
                low_open=True, high_open=True,
            ),
            "transmittance_min": Interval(0, 1, high_open=True),
            "jacobian_margin": Interval(0),
            "tile_size": Interval(1, integer=True),
            "chunk": Interval(1, integer=True),
        }  # fmt: skip
        if self.max_contributors is not None:
            allowed["max_contributors"] = Interval(1, integer=True)
        check_fields("RasterConfig", values, allowed, RenderError)
        if self.backend not in BACKENDS:
            raise RenderError(
                f"RasterConfig.backend={self.backend!r} must be in {', '.join(BACKENDS)}"
            )
        threads = self.threads
        if threads is not None and (
            isinstance(threads, bool) or not isinstance(threads, int) or threads < 1
        ):
            raise RenderError(
                f"RasterConfig.threads={threads!r} must be a positive integer or None"
            )
