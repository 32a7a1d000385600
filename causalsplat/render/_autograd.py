"""Feature rendering as a sparse matrix product with a custom autograd function (imports torch).

With the Gaussian geometry frozen, a view's render of per-Gaussian features ``f`` (N, C)
is ``W @ f`` with the view's CSR weights ``W`` (H*W, N); the gradient with respect to ``f``
is ``W^T @ g``. Nothing is kept between calls: the forward product runs on a torch CSR
tensor that shares the :class:`Contributors` arrays (no copy of the weights when they are
float32, as stored), and the backward product scatters the rows of ``W`` into the
Gaussians (:mod:`causalsplat.render._kernel_transpose` where numba imports, else scipy's
product with the transposed CSR view, which is not materialised either). So a view whose
weights are not in use holds no torch memory, and a view read from a memory-mapped file
is never copied.
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np
import torch

from causalsplat.render._backend import numba_available
from causalsplat.render.types import Contributors

#: Views with fewer weights scatter their backward product on the calling thread.
_THREADED_NNZ = 1 << 22


def _csr_tensor(c: Contributors, dtype: torch.dtype) -> torch.Tensor:
    # int32 indices take the faster CSR kernels (about 2x here) when they fit.
    itype = np.int32 if max(c.nnz, c.n_pixels, c.n_gaussians) < 2**31 - 1 else np.int64
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Sparse CSR tensor support is in beta")
        warnings.filterwarnings("ignore", message="The given NumPy array is not writable")
        return torch.sparse_csr_tensor(
            torch.from_numpy(np.asarray(c.indptr).astype(itype, copy=False)),
            torch.from_numpy(np.asarray(c.indices).astype(itype, copy=False)),
            torch.from_numpy(np.asarray(c.weights)).to(dtype),
            size=(c.n_pixels, c.n_gaussians),
            check_invariants=False,
        )


def _transposed(c: Contributors, grad: torch.Tensor) -> torch.Tensor:
    g = grad.detach().contiguous().numpy()
    if numba_available():
        from causalsplat.render._kernel_transpose import transposed_product

        # As many threads as torch's own products use (``torch.set_num_threads``), but one
        # below _THREADED_NNZ weights: torch's OpenMP workers spin for a while after each
        # of its parallel loops, and Python threads started beside them wait for cores
        # (on the tiny synthetic scene two threads cost 1.7x the CPU time of one).
        threads = torch.get_num_threads() if c.nnz >= _THREADED_NNZ else 1
        out = transposed_product(c.indptr, c.indices, c.weights, g, c.n_gaussians, threads)
    else:
        out = np.asarray(c.matrix(g.dtype).T @ g)
    return torch.from_numpy(out)


class SparseComposite(torch.autograd.Function):
    """``out = W @ features``; backward ``grad_features = W^T @ grad_out``.

    ``W`` is constant (no gradient flows to the weights). The backward is itself a
    :class:`TransposedComposite`, so higher derivatives exist too.
    """

    @staticmethod
    def forward(ctx: Any, features: torch.Tensor, contributors: Contributors) -> torch.Tensor:
        ctx.contributors = contributors
        return torch.sparse.mm(_csr_tensor(contributors, features.dtype), features)

    @staticmethod
    def backward(ctx: Any, grad_out: torch.Tensor) -> tuple[torch.Tensor | None, None]:
        if not ctx.needs_input_grad[0]:
            return None, None
        return TransposedComposite.apply(grad_out, ctx.contributors), None  # type: ignore[no-untyped-call]


class TransposedComposite(torch.autograd.Function):
    """``out = W^T @ grad``; backward ``W @ grad_out`` (a :class:`SparseComposite`)."""

    @staticmethod
    def forward(ctx: Any, grad: torch.Tensor, contributors: Contributors) -> torch.Tensor:
        ctx.contributors = contributors
        return _transposed(contributors, grad)

    @staticmethod
    def backward(ctx: Any, grad_out: torch.Tensor) -> tuple[torch.Tensor | None, None]:
        if not ctx.needs_input_grad[0]:
            return None, None
        return SparseComposite.apply(grad_out, ctx.contributors), None  # type: ignore[no-untyped-call]


def _rows_forward(c: Contributors, pixels: np.ndarray, values: torch.Tensor) -> torch.Tensor:
    return torch.from_numpy(c.composite_rows(pixels, values.detach().numpy()))


def _rows_backward(c: Contributors, pixels: np.ndarray, grad: torch.Tensor) -> torch.Tensor:
    return torch.from_numpy(c.transposed_rows(pixels, grad.detach().numpy()))


class RowsComposite(torch.autograd.Function):
    """``out = W[pixels] @ features`` read in place from the view's CSR (compiled);
    backward ``W[pixels]^T @ grad_out`` (a :class:`RowsTransposedComposite`)."""

    @staticmethod
    def forward(
        ctx: Any, features: torch.Tensor, contributors: Contributors, pixels: np.ndarray
    ) -> torch.Tensor:
        ctx.contributors, ctx.pixels = contributors, pixels
        return _rows_forward(contributors, pixels, features)

    @staticmethod
    def backward(ctx: Any, grad_out: torch.Tensor) -> tuple[torch.Tensor | None, None, None]:
        if not ctx.needs_input_grad[0]:
            return None, None, None
        grad = RowsTransposedComposite.apply(grad_out, ctx.contributors, ctx.pixels)  # type: ignore[no-untyped-call]
        return grad, None, None


class RowsTransposedComposite(torch.autograd.Function):
    """``out = W[pixels]^T @ grad``; backward ``W[pixels] @ grad_out``."""

    @staticmethod
    def forward(
        ctx: Any, grad: torch.Tensor, contributors: Contributors, pixels: np.ndarray
    ) -> torch.Tensor:
        ctx.contributors, ctx.pixels = contributors, pixels
        return _rows_backward(contributors, pixels, grad)

    @staticmethod
    def backward(ctx: Any, grad_out: torch.Tensor) -> tuple[torch.Tensor | None, None, None]:
        if not ctx.needs_input_grad[0]:
            return None, None, None
        out = RowsComposite.apply(grad_out, ctx.contributors, ctx.pixels)  # type: ignore[no-untyped-call]
        return out, None, None


def composite_features(
    contributors: Contributors, features: torch.Tensor, pixels: np.ndarray | None = None
) -> torch.Tensor:
    """(H*W, C) composite of (N, C) features (float32 or float64, CPU), or (P, C) at the
    flat ``pixels`` only (int64, in range: the caller checks)."""
    if pixels is None:
        return SparseComposite.apply(features, contributors)  # type: ignore[no-any-return,no-untyped-call]
    if numba_available():
        return RowsComposite.apply(features, contributors, pixels)  # type: ignore[no-any-return,no-untyped-call]
    return SparseComposite.apply(features, contributors.rows(pixels))  # type: ignore[no-any-return,no-untyped-call]
