"""numpy's BLAS on one thread for the duration of a block (threadpoolctl when installed).

The dense products of a build are small, such as (pixels, masks) by (masks, masks) or
(masks, pixels) by (pixels, C). OpenBLAS still splits them over its worker threads, and
those threads spin-wait between calls; on a host busy with other work one such product,
(8192, 17) by (17, 17), took 9 ms on two threads against 0.1 ms on one. So a build runs
numpy's BLAS on one thread and keeps its cores for the compiled kernels and torch, which
it sets itself (``RasterConfig.threads``).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager


@contextmanager
def single_threaded_blas() -> Iterator[None]:
    """Within the block numpy's BLAS uses one thread; the setting before is restored.

    Without threadpoolctl (the ``field`` extra installs it) the block runs unchanged.
    """
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover - installed with the field extra
        yield
        return
    with threadpool_limits(limits=1, user_api="blas"):
        yield


__all__ = ["single_threaded_blas"]
