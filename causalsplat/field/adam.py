"""Adam on one dense float32 parameter array, in place (numpy).

The update of ``torch.optim.Adam`` with its defaults (no weight decay, no amsgrad)::

    m <- b1 m + (1 - b1) g;   v <- b2 v + (1 - b2) g^2
    p <- p - lr / (1 - b1^t) * m / (sqrt(v) / sqrt(1 - b2^t) + eps)

as one compiled pass over the arrays where numba imports
(:mod:`causalsplat.field._kernel_adam`), else numpy's in-place operations; both do the
same float32 operations in the same order (tests hold them to each other and to torch's
over many steps). The features of a build are one (N, C) float32 array, so nothing more
general is needed.

>>> import numpy as np
>>> p = np.array([1.0, -2.0], dtype=np.float32)
>>> opt = Adam(p, lr=0.1)
>>> opt.step(2 * p)                      # the gradient of sum(p ** 2)
>>> [round(float(x), 4) for x in p]      # the first step moves each entry by lr
[0.9, -1.9]
"""

from __future__ import annotations

import math

import numpy as np

from causalsplat.field.config import FieldConfigError


class Adam:
    """Adam on ``param`` (a writeable float32 numpy array, updated in place).

    Args:
        param: the array to optimise.
        lr: step size (> 0). betas: the moments' decay rates, each in [0, 1). eps: > 0.
        compiled: use the compiled update (default: where numba imports); ``False``
            keeps numpy's operations (the reference the tests compare with).
    """

    def __init__(
        self,
        param: np.ndarray,
        lr: float,
        betas: tuple[float, float] = (0.9, 0.999),
        eps: float = 1e-8,
        *,
        compiled: bool | None = None,
    ) -> None:
        if not isinstance(param, np.ndarray) or param.dtype != np.float32:
            raise FieldConfigError("Adam optimises a float32 numpy array")
        if not param.flags.writeable:
            raise FieldConfigError("Adam updates its array in place: it must be writeable")
        if not lr > 0 or not all(0.0 <= b < 1.0 for b in betas) or not eps > 0:
            raise FieldConfigError("Adam: lr must be > 0, betas in [0, 1) and eps > 0")
        self.param = param
        self.lr, self.betas, self.eps = lr, betas, eps
        if compiled is None:
            from causalsplat.render._backend import numba_available

            compiled = numba_available()
        self.compiled = compiled
        self.m = np.zeros_like(param)
        self.v = np.zeros_like(param)
        self._scratch: np.ndarray | None = None  # numpy's temporary, made on first use
        self.steps = 0

    def step(self, grad: np.ndarray) -> None:
        """One update from ``grad`` (the shape of the parameter)."""
        if grad.shape != self.param.shape:
            raise FieldConfigError(
                f"Adam: gradient of shape {grad.shape} for a parameter of {self.param.shape}"
            )
        self.steps += 1
        b1, b2 = self.betas
        step_size = np.float32(self.lr / (1.0 - b1**self.steps))
        bias2_sqrt = np.float32(math.sqrt(1.0 - b2**self.steps))
        g = np.asarray(grad, dtype=np.float32)
        if self.compiled and self.param.flags.c_contiguous:
            from causalsplat.field._kernel_adam import adam_update

            f32 = np.float32
            adam_update(self.param.reshape(-1), np.ascontiguousarray(g).reshape(-1),
                        self.m.reshape(-1), self.v.reshape(-1), f32(b1), f32(1.0 - b1),
                        f32(b2), f32(1.0 - b2), step_size, bias2_sqrt, f32(self.eps))  # fmt: skip
            return
        if self._scratch is None:
            self._scratch = np.zeros_like(self.param)
        m, v, tmp = self.m, self.v, self._scratch
        m *= np.float32(b1)
        np.multiply(g, np.float32(1.0 - b1), out=tmp)
        m += tmp
        v *= np.float32(b2)
        np.multiply(g, g, out=tmp)
        tmp *= np.float32(1.0 - b2)
        v += tmp
        np.sqrt(v, out=tmp)
        tmp /= bias2_sqrt
        tmp += np.float32(self.eps)
        np.divide(m, tmp, out=tmp)
        tmp *= step_size
        self.param -= tmp


__all__ = ["Adam"]
