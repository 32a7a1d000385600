"""Training-free initialisation: weight-averaged uplift of per-mask codes to the Gaussians.

Every usable mask ``m`` of every view gets a random unit code ``r_m`` (C,). A pixel's code
is the weighted sum of the codes of the masks covering it, ``q(x) = sum_m W_m(x) r_m``, and
a Gaussian's feature the blending-weighted sum over all views and pixels it is drawn into,
``f_g = Norm(sum_v sum_x w_v(x, g) q_v(x))``, i.e. ``f = Norm(sum_v W_v^T (B_v^T R_v))``.
Gaussians of one object fall into the masks of that object in every view that sees them,
so they accumulate the same codes; Gaussians of different objects accumulate independent
codes and are nearly orthogonal when C is large enough. numpy / scipy only.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from causalsplat.field.weights import ViewMasks, normalize_rows
from causalsplat.render.types import Contributors


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
        matrix_t = contrib.matrix(np.float64).T
        if self.codes is not None and vm.n_masks > 0:
            dim = self.codes.shape[1]
            codes = normalize_rows(self._rng.standard_normal((vm.n_masks, dim)))
            pixel_codes = vm.weights.T.astype(np.float64) @ codes  # (H*W, dim)
            self.codes += matrix_t @ pixel_codes
        if vm.pixels.size > 0:
            covered = np.zeros(vm.n_pixels, dtype=np.float64)
            covered[vm.pixels] = 1.0
            self.supervision += matrix_t @ covered


def uplift_codes(
    contributors: Sequence[Contributors],
    masks: Sequence[ViewMasks],
    dim: int,
    rng: np.random.Generator,
) -> np.ndarray:
    """(N, dim) float64 uplifted features (rows of unseen Gaussians are zero)."""
    acc = UpliftAccumulator(contributors[0].n_gaussians if contributors else 0, dim, rng)
    for contrib, vm in zip(contributors, masks, strict=True):
        acc.add(contrib, vm)
    assert acc.codes is not None
    return normalize_rows(acc.codes)


def supervision_weight(
    contributors: Sequence[Contributors], masks: Sequence[ViewMasks]
) -> np.ndarray:
    """(N,) float64: each Gaussian's total blending weight inside usable masks, all views."""
    rng = np.random.default_rng(0)  # unused: no codes
    acc = UpliftAccumulator(contributors[0].n_gaussians if contributors else 0, None, rng)
    for contrib, vm in zip(contributors, masks, strict=True):
        acc.add(contrib, vm)
    return acc.supervision
