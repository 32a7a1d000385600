"""The one numba decorator of the compiled rasterizer (imports numba; imported lazily).

``cache=True`` keeps compiled code in ``__pycache__`` next to the module, or, where that
folder is read-only (an installed wheel), in numba's user cache directory
(``NUMBA_CACHE_DIR`` or ``~/.cache/numba``). Where no folder is writable numba refuses
``cache=True`` at decoration time; the kernels are then compiled in memory each process.
``nogil=True``: the kernels run on several Python threads at once (see
:mod:`causalsplat.render._kernel`). ``error_model="numpy"``: a float division by zero gives
inf or nan, as in numpy, instead of raising; without the check in every division the loops
vectorise (Adam's update: 4.3 ms against 0.5 ms on 1.3 M entries). No fast-math: the
kernels must take the decisions the numpy path and the float64 reference take.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

import numba

F = TypeVar("F", bound=Callable[..., Any])


def jit() -> Callable[[F], F]:
    """``numba.njit(cache=True, nogil=True, error_model="numpy")``, the cache dropped where
    it cannot be kept."""

    def wrap(fn: F) -> F:
        try:
            return numba.njit(cache=True, nogil=True, error_model="numpy")(fn)  # type: ignore[no-any-return]
        except RuntimeError:  # "cannot cache function ...: no locator available for file"
            return numba.njit(cache=False, nogil=True, error_model="numpy")(fn)  # type: ignore[no-any-return]

    return wrap
