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


def uplift_codes(
    contributors: Sequence[Contributors],
    masks: Sequence[ViewMasks],
    dim: int,
    rng: np.random.Generator,
) -> np.ndarray:
    """(N, dim) float64 uplifted features (rows of unseen Gaussians are zero)."""
    n = contributors[0].n_gaussians if contributors else 0
    acc = np.zeros((n, dim), dtype=np.float64)
    for contrib, vm in zip(contributors, masks, strict=True):
        if vm.n_masks == 0:
            continue
        codes = normalize_rows(rng.standard_normal((vm.n_masks, dim)))
        pixel_codes = vm.weights.T.astype(np.float64) @ codes  # (H*W, dim)
        acc += contrib.matrix(np.float64).T @ pixel_codes
    return normalize_rows(acc)


def supervision_weight(
    contributors: Sequence[Contributors], masks: Sequence[ViewMasks]
) -> np.ndarray:
    """(N,) float64: each Gaussian's total blending weight inside usable masks, all views."""
    n = contributors[0].n_gaussians if contributors else 0
    total = np.zeros(n, dtype=np.float64)
    for contrib, vm in zip(contributors, masks, strict=True):
        if vm.pixels.size == 0:
            continue
        covered = np.zeros(vm.n_pixels, dtype=np.float64)
        covered[vm.pixels] = 1.0
        total += contrib.matrix(np.float64).T @ covered
    return total
