"""Training-free initialisation: weight-averaged uplift of per-mask codes to the Gaussians.

Every usable mask ``m`` of every view gets a random unit code ``r_m`` (C,). A pixel's code
is the weighted sum of the codes of the masks covering it, ``q(x) = sum_m W_m(x) r_m``, and
a Gaussian's feature the blending-weighted sum over all views and pixels it is drawn into,
``f_g = Norm(sum_v sum_x w_v(x, g) q_v(x))``, i.e. ``f = Norm(sum_v W_v^T (B_v^T R_v))``.
Gaussians of one object fall into the masks of that object in every view that sees them,
so they accumulate the same codes; Gaussians of different objects accumulate independent
codes and are nearly orthogonal when C is large enough. The sums are taken one view at a
time by :class:`UpliftAccumulator`, while the build rasterizes the views
(:func:`causalsplat.field.prepare_views`). numpy / scipy only.
"""

from __future__ import annotations

import numpy as np

from causalsplat.field.weights import ViewMasks, normalize_rows
from causalsplat.render.types import Contributors


def _transposed(contrib: Contributors, values: np.ndarray) -> np.ndarray:
    """``W^T @ values`` in float64 without a float64 copy of the weights: the compiled
    scatter on one thread (independent of the thread count), else scipy."""
    from causalsplat.render._backend import numba_available

    if numba_available():
        from causalsplat.render._kernel_transpose import transposed_product

        c = contrib
        return transposed_product(c.indptr, c.indices, c.weights, values, c.n_gaussians, 1)
    return np.asarray(contrib.matrix(np.float64).T @ values)


class UpliftAccumulator:
    """The uplift and the supervision weight summed one view at a time, so that a build
    reads each view's weights once for both (while it rasterizes them)."""

    def __init__(self, n: int, dim: int | None, rng: np.random.Generator) -> None:
        self.codes = None if dim is None else np.zeros((n, dim), dtype=np.float64)
        self.supervision = np.zeros(n, dtype=np.float64)
        self._rng = rng

    def add(self, contrib: Contributors, vm: ViewMasks) -> None:
        """Add one view (views in order: the codes are drawn from the generator)."""
        if vm.pixels.size == 0 and vm.n_masks == 0:
            return
        # One pass over the view's weights for both sums: (H*W, dim + 1) values per pixel.
        with_codes = self.codes is not None and vm.n_masks > 0
        dim = self.codes.shape[1] if with_codes and self.codes is not None else 0
        values = np.zeros((vm.n_pixels, dim + 1), dtype=np.float64)
        if with_codes:
            codes = normalize_rows(self._rng.standard_normal((vm.n_masks, dim)))
            values[:, :dim] = vm.weights.T.astype(np.float64) @ codes
        values[vm.pixels, dim] = 1.0
        summed = _transposed(contrib, values)
        if with_codes and self.codes is not None:
            self.codes += summed[:, :dim]
        self.supervision += summed[:, dim]
