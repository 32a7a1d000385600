"""The blending weight each Gaussian carries inside each mask of a view: ``B @ W``.

``B`` (M, H*W) holds the view's weighted masks (:class:`~causalsplat.field.weights.ViewMasks`)
and ``W`` (H*W, N) its blending weights; row ``m`` of the product is
``sum_x B_m(x) w(x, g)`` per Gaussian ``g``. The instance stage's evidence stacks these
rows, and the uplift is ``(B @ W)^T R`` for the masks' codes ``R`` (no per-pixel codes).
Compiled (:mod:`causalsplat.field._kernel_evidence`) where numba imports, else scipy.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from causalsplat.field.weights import ViewMasks
from causalsplat.render.types import Contributors


def mask_gaussian_weights(vm: ViewMasks, contrib: Contributors) -> sp.csr_matrix:
    """(M, N) float64 ``B @ W`` of one view (module docstring)."""
    from causalsplat.render._backend import numba_available

    if not numba_available():
        return sp.csr_matrix(vm.weights.astype(np.float64) @ contrib.matrix(np.float64))
    from causalsplat.field._kernel_evidence import mask_times_weights

    b = vm.weights
    parts = mask_times_weights(b.indptr, b.indices, b.data, contrib.indptr, contrib.indices,
                               contrib.weights, contrib.n_gaussians)  # fmt: skip
    return sp.csr_matrix(parts[::-1], shape=(vm.n_masks, contrib.n_gaussians))


__all__ = ["mask_gaussian_weights"]
