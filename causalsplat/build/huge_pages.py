"""numpy's huge-page advice, off for the duration of a build (``BuildConfig.huge_pages``).

On Linux numpy asks the kernel for transparent huge pages (``madvise(MADV_HUGEPAGE)``) on
each array of 4 MiB or more. A build allocates about a GiB of such arrays on
scene0000_00 (each view's blending weights, the rasterizer's scratch, the training's
per-view terms) and frees much of it again. Where the first touch of a 2 MiB page is
dear, as in virtual machines that hand freed memory back to their host, the advice costs
more than it saves: on the 2-core VM of ``docs/benchmarks.md``, rasterizing
scene0000_00's 63 views on one thread took 4.4 s with it (2.2 s of it in the kernel's
page faults) and 2.7 s without it, at equal user time. So a build runs without it unless
``BuildConfig.huge_pages`` is true, and the setting before is restored afterwards.
Elsewhere the block changes nothing (numpy without the switch, other platforms).

>>> with huge_page_advice(False):
...     pass
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager


def _switch() -> Callable[[bool], bool] | None:
    """numpy's setter (returns the previous setting), where this numpy has one."""
    import numpy as np

    for module in ("_core", "core"):
        multiarray = getattr(getattr(np, module, None), "multiarray", None)
        setter = getattr(multiarray, "_set_madvise_hugepage", None)
        if callable(setter):
            return setter  # type: ignore[no-any-return]
    return None


@contextmanager
def huge_page_advice(enabled: bool) -> Iterator[None]:
    """Within the block numpy advises huge pages for its large arrays iff ``enabled``."""
    setter = _switch()
    if setter is None:
        yield
        return
    before = setter(enabled)
    try:
        yield
    finally:
        setter(before)


__all__ = ["huge_page_advice"]
