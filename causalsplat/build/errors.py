"""Errors of the build pipeline."""

from __future__ import annotations

from causalsplat.errors import CausalSplatError


class BuildError(CausalSplatError):
    """The inputs are well formed but give nothing to build from (no view sees a masked
    Gaussian, say); the message says what was found and which option to check."""


class CoverageError(BuildError):
    """The PLY and the cameras (or masks) do not belong together: the views see too few
    Gaussians, or the masks fall where no Gaussian projects
    (:mod:`causalsplat.build.coverage`); the message gives both shares and thresholds."""
