"""Images for chat messages: arrays as base64 PNG data URLs (no imaging library needed)."""

from __future__ import annotations

import base64
import struct
import zlib
from typing import Any

import numpy as np

from causalsplat.openai_compat.errors import VLMError


class ImageFormatError(VLMError, ValueError):
    """An array is not an image (shape, dtype or size)."""


def encode_png(image: np.ndarray) -> bytes:
    """PNG bytes of an ``(H, W)`` grey, ``(H, W, 3)`` RGB or ``(H, W, 4)`` RGBA image.

    ``uint8`` arrays are written as is; float arrays are read as ``[0, 1]`` and rounded;
    bool arrays (masks) become black and white.
    """
    array = np.asarray(image)
    if array.dtype == np.bool_:
        array = array.astype(np.uint8) * 255
    elif np.issubdtype(array.dtype, np.floating):
        if not np.isfinite(array).all():
            raise ImageFormatError("image has NaN or infinite values")
        array = np.round(np.clip(array, 0.0, 1.0) * 255.0).astype(np.uint8)
    elif array.dtype != np.uint8:
        raise ImageFormatError(f"image dtype {array.dtype} is not uint8, float or bool")
    if array.ndim == 2:
        colour_type, channels = 0, 1
    elif array.ndim == 3 and array.shape[2] in (3, 4):
        colour_type, channels = (2 if array.shape[2] == 3 else 6), array.shape[2]
    else:
        raise ImageFormatError(f"image shape {array.shape} is not (H, W), (H, W, 3) or (H, W, 4)")
    h, w = array.shape[:2]
    if h == 0 or w == 0:
        raise ImageFormatError(f"image is empty ({h}x{w})")
    rows = np.ascontiguousarray(array).reshape(h, w * channels)
    raw = b"".join(b"\x00" + rows[y].tobytes() for y in range(h))

    def chunk(tag: bytes, data: bytes) -> bytes:
        body = tag + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body))

    header = struct.pack(">IIBBBBB", w, h, 8, colour_type, 0, 0, 0)
    return (
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", header)
        + chunk(b"IDAT", zlib.compress(raw, 6))
        + chunk(b"IEND", b"")
    )


def image_data_url(image: np.ndarray) -> str:
    """``data:image/png;base64,...`` for an image array."""
    return "data:image/png;base64," + base64.b64encode(encode_png(image)).decode("ascii")


def image_part(image: np.ndarray) -> dict[str, Any]:
    """A chat-message content part carrying an image."""
    return {"type": "image_url", "image_url": {"url": image_data_url(image)}}
