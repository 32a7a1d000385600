"""Spatially weighted masks: per-pixel weights of a 2D mask and the mask feature they give.

The method weights each pixel ``x`` of a mask by its distance ``d(x)`` to the mask's
geometric centre (the mean of its pixel centres)::

    W(x) = w_min + (1 - w_min) * (1 - d(x) / (d_max + eps))      for x in the mask, else 0

so the centre counts fully and the boundary, where 2D masks are least reliable, counts
``w_min``. A mask's feature is ``p = Norm(sum_x W(x) F(x))`` over the (per-pixel
normalised) rendered feature map ``F``. ``average`` (W = 1) and ``random``
(W ~ U(w_min, 1)) are the ablation's alternatives. numpy / scipy only.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from causalsplat.field.config import FieldConfig, FieldConfigError
from causalsplat.masks import MaskSet


def mask_weights(
    mask: np.ndarray,
    *,
    weighting: str = "spatial",
    w_min: float = 0.4,
    eps: float = 1e-6,
    rng: np.random.Generator | None = None,
) -> np.ndarray:
    """(H, W) float64 pixel weights of one (H, W) bool mask (module docstring); 0 outside.

    An empty mask gives all zeros; a one-pixel mask gives 1 on its pixel (``d = d_max = 0``).
    ``random`` needs ``rng``.
    """
    mask = np.asarray(mask, dtype=bool)
    if mask.ndim != 2:
        raise FieldConfigError(f"mask_weights: expected an (H, W) mask, got shape {mask.shape}")
    out = np.zeros(mask.shape, dtype=np.float64)
    rows, cols = np.nonzero(mask)
    if rows.size == 0:
        return out
    out[rows, cols] = _pixel_weights(rows, cols, weighting, w_min, eps, rng)
    return out


def _pixel_weights(
    rows: np.ndarray,
    cols: np.ndarray,
    weighting: str,
    w_min: float,
    eps: float,
    rng: np.random.Generator | None,
) -> np.ndarray:
    if weighting == "average":
        return np.ones(rows.shape[0])
    if weighting == "random":
        if rng is None:
            raise FieldConfigError("random weighting needs a random generator")
        return rng.uniform(w_min, 1.0, size=rows.shape[0])
    if weighting != "spatial":
        raise FieldConfigError(f"unknown weighting {weighting!r}")
    # Pixel centres at half-integers; the centre is their mean (float64 sums are exact here).
    y = rows.astype(np.float64) + 0.5
    x = cols.astype(np.float64) + 0.5
    d = np.hypot(x - x.mean(), y - y.mean())
    return w_min + (1.0 - w_min) * (1.0 - d / (d.max() + eps))


@dataclass(frozen=True, slots=True)
class ViewMasks:
    """The usable masks of one view as a weighted sparse matrix over its pixels.

    Attributes:
        view: position of the view in the build's view list.
        mask_index: (M,) int64, index of each row's mask in the view's :class:`MaskSet`.
        weights: (M, H*W) float32 CSR, ``W_m(x)`` of mask ``m`` at flat pixel ``x``.
        pixels: (P,) int64 flat indices of the pixels covered by at least one usable mask.
        n_pixels: H*W.
    """

    view: int
    mask_index: np.ndarray
    weights: sp.csr_matrix
    pixels: np.ndarray
    n_pixels: int

    @property
    def n_masks(self) -> int:
        return int(self.mask_index.shape[0])

    def on_pixels(self) -> sp.csr_matrix:
        """(M, P) weights restricted to the covered pixels (columns in ``pixels`` order)."""
        return self.weights[:, self.pixels].tocsr()


def view_masks(
    maskset: MaskSet,
    view: int,
    config: FieldConfig,
    rng: np.random.Generator,
    *,
    valid: np.ndarray | None = None,
) -> ViewMasks:
    """The weighted matrix of a view's masks with at least ``config.min_mask_pixels`` pixels.

    ``valid``: optional (H, W) bool; mask pixels outside it are dropped before weighting
    (the pixels where the scene draws nothing, see ``FieldConfig.min_pixel_alpha``).
    """
    n_pixels = maskset.height * maskset.width
    if valid is not None and np.asarray(valid).shape != (maskset.height, maskset.width):
        raise FieldConfigError(
            f"view {maskset.view!r}: valid-pixel map of shape {np.asarray(valid).shape} for "
            f"{maskset.width}x{maskset.height} masks"
        )
    keep_px = None if valid is None else np.asarray(valid, dtype=bool).ravel()
    rows: list[np.ndarray] = []
    cols: list[np.ndarray] = []
    vals: list[np.ndarray] = []
    kept: list[int] = []
    flat = maskset.masks.reshape(maskset.n, maskset.masks.shape[1] * maskset.masks.shape[2])
    for i in range(maskset.n):
        pix = np.flatnonzero(flat[i] if keep_px is None else flat[i] & keep_px)
        if pix.size < config.min_mask_pixels:
            continue
        r, c = np.divmod(pix, maskset.width)
        w = _pixel_weights(r, c, config.weighting, config.w_min, config.eps, rng)
        rows.append(np.full(pix.size, len(kept), dtype=np.int64))
        cols.append(pix)
        vals.append(w)
        kept.append(i)
    if kept:
        matrix = sp.csr_matrix(
            (np.concatenate(vals).astype(np.float32), (np.concatenate(rows), np.concatenate(cols))),
            shape=(len(kept), n_pixels),
        )
        covered = np.zeros(n_pixels, dtype=bool)  # a flag per pixel: no sort, as unique does
        for c in cols:
            covered[c] = True
        pixels = np.flatnonzero(covered)
    else:
        matrix = sp.csr_matrix((0, n_pixels), dtype=np.float32)
        pixels = np.zeros(0, dtype=np.int64)
    return ViewMasks(view, np.asarray(kept, dtype=np.int64), matrix, pixels, n_pixels)


def mask_features(feature_map: np.ndarray, masks: ViewMasks, eps: float = 1e-12) -> np.ndarray:
    """(M, C) float32 ``Norm(sum_x W_m(x) F(x))`` from an (H*W, C) rendered feature map.

    Pixel features are L2-normalised first (a pixel's composite has the norm of its alpha);
    a mask whose weighted sum vanishes gets a zero row.
    """
    f = np.asarray(feature_map, dtype=np.float64)
    norms = np.linalg.norm(f, axis=1, keepdims=True)
    unit = np.divide(f, norms, out=np.zeros_like(f), where=norms > eps)
    summed = np.asarray(masks.weights.astype(np.float64) @ unit)
    return normalize_rows(summed, eps).astype(np.float32)


def normalize_rows(x: np.ndarray, eps: float = 1e-12) -> np.ndarray:
    """Rows divided by their L2 norm (rows with norm <= eps become zero), float64."""
    x = np.asarray(x, dtype=np.float64)
    norms = np.linalg.norm(x, axis=1, keepdims=True)
    return np.divide(x, norms, out=np.zeros_like(x), where=norms > eps)
