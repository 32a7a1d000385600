"""2D masks per view: the :class:`MaskSet` type, its ``.npz`` file format, GT masks from
instance-id renders, and a documented SAM-like noise model (:mod:`causalsplat.masks.noise`).
Masks other tools wrote are read by :mod:`causalsplat.masks.convert`; SAM or SAM 2 run here
from a checkpoint the user has through :mod:`causalsplat.masks.generate`.

numpy/scipy only: ``generate`` imports torch and the model's package when it runs.
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
