"""Adam on one dense parameter tensor, without ``torch.optim`` (imports torch).

The features of a build are one (N, C) float32 leaf tensor. ``torch.optim.Adam`` costs
about a second to construct (its first use imports torch's compiler stack, here 0.9 s of a
build that takes a few); this is the same update in torch's in-place operations:

    m <- b1 m + (1 - b1) g;   v <- b2 v + (1 - b2) g^2
    p <- p - lr / (1 - b1^t) * m / (sqrt(v) / sqrt(1 - b2^t) + eps)

which is ``torch.optim.Adam`` with its defaults (no weight decay, no amsgrad), up to the
rounding of float32 operations done in another order.

>>> import torch
>>> p = torch.tensor([1.0, -2.0], requires_grad=True)
>>> opt = Adam(p, lr=0.1)
>>> (p ** 2).sum().backward()
>>> opt.step()
>>> [round(x, 4) for x in p.tolist()]    # the first step moves each entry by lr
[0.9, -1.9]
"""

from __future__ import annotations

import math

import torch

from causalsplat.field.config import FieldConfigError


class Adam:
    """Adam on ``param`` (a float32 CPU leaf tensor with ``requires_grad``).

    Args:
        param: the tensor to optimise; its ``.grad`` is read at each :meth:`step`.
        lr: step size (> 0). betas: the moments' decay rates, each in [0, 1). eps: > 0.
    """

    def __init__(
        self,
        param: torch.Tensor,
        lr: float,
        betas: tuple[float, float] = (0.9, 0.999),
        eps: float = 1e-8,
    ) -> None:
        if param.dtype != torch.float32 or not param.is_leaf:
            raise FieldConfigError("Adam optimises a float32 leaf tensor")
        if not lr > 0 or not all(0.0 <= b < 1.0 for b in betas) or not eps > 0:
            raise FieldConfigError("Adam: lr must be > 0, betas in [0, 1) and eps > 0")
        self.param = param
        self.lr, self.betas, self.eps = lr, betas, eps
        self.m = torch.zeros_like(param, memory_format=torch.contiguous_format)
        self.v = torch.zeros_like(param, memory_format=torch.contiguous_format)
        self.steps = 0

    def zero_grad(self) -> None:
        """Drop the gradient (the next backward pass writes a new one)."""
        self.param.grad = None

    @torch.no_grad()
    def step(self) -> None:
        """One update from ``param.grad`` (nothing when there is no gradient)."""
        grad = self.param.grad
        if grad is None:
            return
        self.steps += 1
        b1, b2 = self.betas
        step_size = self.lr / (1.0 - b1**self.steps)
        bias2_sqrt = math.sqrt(1.0 - b2**self.steps)
        self.m.mul_(b1).add_(grad, alpha=1.0 - b1)
        self.v.mul_(b2).addcmul_(grad, grad, value=1.0 - b2)
        denom = self.v.sqrt().div_(bias2_sqrt).add_(self.eps)
        self.param.addcdiv_(self.m, denom, value=-step_size)


__all__ = ["Adam"]
