"""Errors of the scene loaders; all derive from :class:`causalsplat.errors.InputFormatError`.

Every message names the file (where there is one) and the offending property or value.
"""

from __future__ import annotations

from causalsplat.errors import InputFormatError


class InvalidSceneError(InputFormatError):
    """Arrays given to :class:`~causalsplat.io.types.GaussianScene` or
    :class:`~causalsplat.io.types.Camera` have a wrong shape, a non-finite value, or a
    zero quaternion."""


class PlyFormatError(InputFormatError):
    """A 3DGS PLY file is truncated, lacks a property, has a wrong SH count or NaN/Inf."""


class ColmapFormatError(InputFormatError):
    """A COLMAP sparse model (text or binary) is malformed, truncated or unsupported."""


class ColmapDistortionError(ColmapFormatError):
    """A COLMAP camera has non-zero lens distortion and the reader was not allowed to drop
    it (``allow_distortion=False``)."""


class TransformsFormatError(InputFormatError):
    """A nerfstudio / instant-ngp ``transforms.json`` is malformed."""
