"""CPU rasterizer of 3D Gaussian scenes: blending weights, RGB, depth, id maps and features.

Public API in :mod:`causalsplat.render.functional` (re-exported here); importing this
package does not import torch (only :func:`render_features` does).
"""

from causalsplat.render._cache import (
    clear_contributor_cache,
    contributor_cache_info,
    set_contributor_cache_limit,
)
from causalsplat.render.config import RasterConfig
from causalsplat.render.errors import RenderError
from causalsplat.render.functional import (
    build_contributors,
    render_alpha,
    render_depth,
    render_features,
    render_ids,
    render_rgb,
)
from causalsplat.render.types import Contributors

__all__ = [
    "Contributors",
    "RasterConfig",
    "RenderError",
    "build_contributors",
    "clear_contributor_cache",
    "contributor_cache_info",
    "render_alpha",
    "render_depth",
    "render_features",
    "render_ids",
    "render_rgb",
    "set_contributor_cache_limit",
]
