"""The semantic feature field: multi-view 2D masks lifted to per-Gaussian features.

Spatially weighted mask features (:mod:`causalsplat.field.weights`), a training-free
uplift (:mod:`causalsplat.field.uplift`) and contrastive optimisation through the
cached-weight renderer (:mod:`causalsplat.field.train`, the only module that imports
torch). Entry points: :func:`prepare_views`, :func:`lift_features`,
:func:`mask_evidence`.
"""

from causalsplat.field.config import FieldConfig, FieldConfigError
from causalsplat.field.lift import LiftedViews, lift_features, mask_evidence, prepare_views
from causalsplat.field.types import FeatureField, MaskEvidence
from causalsplat.field.weights import ViewMasks, mask_features, mask_weights

__all__ = [
    "FeatureField",
    "FieldConfig",
    "FieldConfigError",
    "LiftedViews",
    "MaskEvidence",
    "ViewMasks",
    "lift_features",
    "mask_evidence",
    "mask_features",
    "mask_weights",
    "prepare_views",
]
