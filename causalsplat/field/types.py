"""The feature field's hand-off type (numpy only)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from causalsplat.field.config import FieldConfig


@dataclass(frozen=True, slots=True, eq=False)
class FeatureField:
    """Per-Gaussian semantic features lifted from multi-view masks.

    Attributes:
        features: (N, C) float32, L2-normalised rows; zero rows for pruned Gaussians.
        active: (N,) bool, Gaussians kept by the opacity pruning (rendered and trained).
        supervised: (N,) bool, active Gaussians that carry blending weight inside some
            usable mask of some view; the others never received a training signal and
            their features mean nothing.
        losses: the contrastive loss of each training step (empty without training).
        config: the options that made it.
    """

    features: np.ndarray
    active: np.ndarray
    supervised: np.ndarray
    losses: tuple[float, ...]
    config: FieldConfig

    @property
    def n(self) -> int:
        return int(self.features.shape[0])

    @property
    def dim(self) -> int:
        return int(self.features.shape[1])


@dataclass(frozen=True, slots=True, eq=False)
class MaskEvidence:
    """The usable masks of all views, one row each (view order, then mask order).

    Attributes:
        view: (M,) int64 view of each mask (position in the build's view list).
        index: (M,) int64 index of the mask in its view's :class:`~causalsplat.masks.MaskSet`.
        pixel_weight: (M,) float64 sum of the mask's pixel weights ``sum_x W_m(x)``.
        features: (M, C) float32 unit mask features ``Norm(sum_x W_m(x) F̂(x))``.
        gaussian_weight: (M, N) float64 CSR, ``sum_x W_m(x) w(x, g)``: how much of
            Gaussian ``g`` is drawn inside mask ``m`` (full-scene Gaussian indices).
    """

    view: np.ndarray
    index: np.ndarray
    pixel_weight: np.ndarray
    features: np.ndarray
    gaussian_weight: sp.csr_matrix

    @property
    def n(self) -> int:
        return int(self.view.shape[0])
