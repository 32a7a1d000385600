"""Errors of scene-graph construction (:mod:`causalsplat.graph`)."""

from __future__ import annotations

from causalsplat.errors import CausalSplatError


class GraphBuildError(CausalSplatError, ValueError):
    """Root of the errors raised while building a scene graph."""


class EdgeConfigError(GraphBuildError):
    """An :class:`~causalsplat.graph.config.EdgeConfig` value is out of range.

    The message names the field and the value.
    """


class EdgeInputError(GraphBuildError):
    """The entities handed to the edge builder cannot be related.

    Raised for a non-entity item, a duplicate entity id, an unknown up axis, or
    coordinates so large (beyond ``1e100`` scene units) that squared distances would
    overflow float64. The message names the value.
    """
