"""Which path builds a view's contributors: the compiled kernel when numba imports, else numpy.

numba is imported here only when a view is rasterized, never by ``import causalsplat``.
"""

from __future__ import annotations

import functools
from typing import Literal

from causalsplat.errors import MissingDependencyError
from causalsplat.io.types import Camera, GaussianScene
from causalsplat.render.config import RasterConfig
from causalsplat.render.types import Contributors


@functools.cache
def numba_available() -> bool:
    """Whether numba (and its compiled kernels' module) imports in this environment."""
    try:
        import causalsplat.render._kernel  # noqa: F401
    except (ImportError, OSError):  # not installed, or built for another numpy / platform
        return False
    return True


def resolve_backend(config: RasterConfig) -> Literal["numba", "numpy"]:
    """The path ``config.backend`` selects (``auto``: numba when available)."""
    if config.backend == "numpy":
        return "numpy"
    if numba_available():
        return "numba"
    if config.backend == "numba":
        raise MissingDependencyError(
            "RasterConfig.backend='numba' needs numba: pip install 'causalsplat[build]' "
            "(or use backend='auto' to fall back to the numpy path)"
        )
    return "numpy"


def compute_contributors(
    scene: GaussianScene, camera: Camera, config: RasterConfig, key: str
) -> Contributors:
    """Build the :class:`Contributors` of a view with the selected path (no caching here)."""
    if resolve_backend(config) == "numba":
        from causalsplat.render._kernel import compute_contributors_numba

        return compute_contributors_numba(scene, camera, config, key)
    from causalsplat.render._contributors import compute_contributors_numpy

    return compute_contributors_numpy(scene, camera, config, key)
