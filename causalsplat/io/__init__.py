"""Scene loaders: 3DGS PLY, COLMAP sparse models and ``transforms.json``, into one pair of types.

:class:`GaussianScene` and :class:`Camera` (OpenCV convention, world-to-camera; see
:mod:`causalsplat.io.types`). Importing this package imports neither torch nor plyfile.
"""

from causalsplat.io.colmap import ColmapModel, ColmapPoints, read_colmap_model, write_colmap_model
from causalsplat.io.errors import (
    ColmapDistortionError,
    ColmapFormatError,
    InvalidSceneError,
    PlyFormatError,
    TransformsFormatError,
)
from causalsplat.io.ply import GaussianPly, PlyLayout, read_gaussian_ply, read_ply, write_ply
from causalsplat.io.transforms_json import read_transforms_json, write_transforms_json
from causalsplat.io.types import SH_C0, Camera, GaussianScene, Projection

__all__ = [
    "SH_C0",
    "Camera",
    "ColmapDistortionError",
    "ColmapFormatError",
    "ColmapModel",
    "ColmapPoints",
    "GaussianPly",
    "GaussianScene",
    "InvalidSceneError",
    "PlyFormatError",
    "PlyLayout",
    "Projection",
    "TransformsFormatError",
    "read_colmap_model",
    "read_gaussian_ply",
    "read_ply",
    "read_transforms_json",
    "write_colmap_model",
    "write_ply",
    "write_transforms_json",
]
