"""Adam's update as one compiled pass over the parameter (imports numba; imported lazily).

:class:`causalsplat.field.adam.Adam` runs it where numba imports: numpy's in-place
sequence reads and writes the (N, C) arrays ten times a step, this loop once, and the
build's 300 steps over 81k x 16 features go from about 2 ms to 0.5 ms each. The
arithmetic is numpy's, operation for operation in float32 (every scalar is passed as a
float32), so both paths give the same bits (a test holds them to each other and to
``torch.optim.Adam``).
"""

from __future__ import annotations

import numpy as np

from causalsplat.render._jit import jit


@jit()
def adam_update(  # pragma: no cover - compiled
    param: np.ndarray,
    grad: np.ndarray,
    m: np.ndarray,
    v: np.ndarray,
    b1: np.float32,
    c1: np.float32,
    b2: np.float32,
    c2: np.float32,
    step_size: np.float32,
    bias2_sqrt: np.float32,
    eps: np.float32,
) -> None:
    """One Adam step on flat float32 arrays, in place (``c1 = 1 - b1``, ``c2 = 1 - b2``)."""
    for i in range(param.shape[0]):
        g = grad[i]
        mi = m[i] * b1 + g * c1
        vi = v[i] * b2 + (g * g) * c2
        m[i] = mi
        v[i] = vi
        param[i] -= (mi / (np.sqrt(vi) / bias2_sqrt + eps)) * step_size


__all__ = ["adam_update"]
