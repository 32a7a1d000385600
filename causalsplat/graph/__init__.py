"""Scene-graph construction: entities to a typed scene graph with spatial edges.

:func:`build_relations` computes the stored relations (above/below, supported_by/supports,
inside/contains, near, next_to) between entities, with the thresholds of
:class:`EdgeConfig` (DESIGN §7).
"""

from causalsplat.graph.config import EdgeConfig
from causalsplat.graph.edges import build_relations, build_relations_bruteforce
from causalsplat.graph.errors import EdgeConfigError, EdgeInputError, GraphBuildError

__all__ = [
    "EdgeConfig",
    "EdgeConfigError",
    "EdgeInputError",
    "GraphBuildError",
    "build_relations",
    "build_relations_bruteforce",
]
