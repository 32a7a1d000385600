"""2D masks per view: the :class:`MaskSet` type, its ``.npz`` file format, GT masks from
instance-id renders, and a documented SAM-like noise model (:mod:`causalsplat.masks.noise`).

numpy/scipy only (no torch).
"""

from causalsplat.masks.files import read_mask_dir, read_masks, write_masks, write_npz
from causalsplat.masks.noise import InvalidNoiseError, NoiseConfig, perturb_masks
from causalsplat.masks.types import (
    MaskFormatError,
    MaskSet,
    id_map_from_masks,
    masks_from_id_render,
)

__all__ = [
    "InvalidNoiseError",
    "MaskFormatError",
    "MaskSet",
    "NoiseConfig",
    "id_map_from_masks",
    "masks_from_id_render",
    "perturb_masks",
    "read_mask_dir",
    "read_masks",
    "write_masks",
    "write_npz",
]
