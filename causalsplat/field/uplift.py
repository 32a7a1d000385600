"""Training-free initialisation: weight-averaged uplift of per-mask codes to the Gaussians.

Every usable mask ``m`` of every view gets a random unit code ``r_m`` (C,). A pixel's code
is the weighted sum of the codes of the masks covering it, ``q(x) = sum_m W_m(x) r_m``, and
a Gaussian's feature the blending-weighted sum over all views and pixels it is drawn into,
``f_g = Norm(sum_v sum_x w_v(x, g) q_v(x))``, i.e. ``f = Norm(sum_v W_v^T (B_v^T R_v))``,
computed as ``(B_v W_v)^T R_v`` (:mod:`causalsplat.field.mask_gaussians`).
Gaussians of one object fall into the masks of that object in every view that sees them,
so they accumulate the same codes; Gaussians of different objects accumulate independent
codes and are nearly orthogonal when C is large enough. The sums are taken one view at a
time by :class:`UpliftAccumulator`, while the build rasterizes the views
(:func:`causalsplat.field.prepare_views`). numpy / scipy only.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from causalsplat.field.mask_gaussians import mask_gaussian_weights
from causalsplat.field.weights import ViewMasks, normalize_rows
from causalsplat.render.types import Contributors


class UpliftAccumulator:
    """The uplift and the supervision weight summed one view at a time, while the build
    rasterizes the views (no later pass reads the views again for them)."""

    def __init__(self, n: int, dim: int | None, rng: np.random.Generator) -> None:
        self.codes = None if dim is None else np.zeros((n, dim), dtype=np.float64)
        self.supervision = np.zeros(n, dtype=np.float64)
        self._rng = rng

    def add(
        self, contrib: Contributors, vm: ViewMasks, product: sp.csr_matrix | None = None
    ) -> None:
        """Add one view (views in order: the codes are drawn from the generator).

        ``product``: the view's ``B @ W`` when the caller has it (else computed here).
        """
        if vm.pixels.size == 0 and vm.n_masks == 0:
            return
        if self.codes is not None and vm.n_masks > 0:
            dim = self.codes.shape[1]
            codes = normalize_rows(self._rng.standard_normal((vm.n_masks, dim)))
            # W^T (B^T R) = (B W)^T R: one pass over the masks' pixels, not C + 1 channels
            # scattered over every weight of the view.
            if product is None:
                product = mask_gaussian_weights(vm, contrib)
            self.codes += np.asarray(product.T @ codes)
        ones = np.ones((vm.pixels.shape[0], 1))
        self.supervision += contrib.transposed_rows(vm.pixels, ones)[:, 0]
