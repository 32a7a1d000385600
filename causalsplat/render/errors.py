"""Errors of the rasterizer."""

from __future__ import annotations

from causalsplat.errors import CausalSplatError


class RenderError(CausalSplatError, ValueError):
    """A scene, camera, feature array or configuration cannot be rendered.

    Raised, for instance, when a Gaussian's covariance overflows float64 (log-scales of
    several hundred), when features do not have one row per Gaussian, or when a config
    value is out of range. The message names the value.
    """
