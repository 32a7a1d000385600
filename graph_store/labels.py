"""Compact per-Gaussian entity labels.

A built scene keeps, for each of its N Gaussians, the local id of the entity it belongs
to (``-1``: none). That array is what turns a persisted answer back into a 3D mask (and,
through the renderer, 2D masks) without retraining. It is stored as one row per scene:
little-endian int32, zlib-compressed, with its length and SHA-256 checked on load.
"""

from __future__ import annotations

import hashlib
import zlib
from collections.abc import Collection
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from graph_store.errors import GraphStoreError, InvalidSceneError

_DTYPE = "<i4"
_CODEC = "zlib"


@dataclass(frozen=True, slots=True)
class EncodedLabels:
    """A label array as stored: ``count`` int32 values, compressed ``data``."""

    count: int
    dtype: str
    codec: str
    sha256: str
    data: bytes


def check_labels(
    labels: object, entity_ids: Collection[int], scene_id: str
) -> npt.NDArray[np.int32]:
    """Validate a label array: 1-D integers, each ``-1`` or the id of an entity of the scene."""
    array = np.asarray(labels)
    where = f"gaussian labels of scene {scene_id!r}"
    if array.ndim != 1:
        raise InvalidSceneError(f"{where} must be a 1-D array, got shape {array.shape}")
    if array.size and not np.issubdtype(array.dtype, np.integer):
        raise InvalidSceneError(f"{where} must be integers, got dtype {array.dtype}")
    values = array.astype(np.int64, copy=False)
    if values.size and (values.min() < -1 or values.max() > np.iinfo(np.int32).max):
        raise InvalidSceneError(
            f"{where} must be -1 or entity ids, got {values.min()}..{values.max()}"
        )
    used = np.unique(values[values >= 0])
    if used.size:
        known = np.fromiter(entity_ids, dtype=np.int64, count=len(entity_ids))
        missing = np.setdiff1d(used, known)
        if missing.size:
            raise InvalidSceneError(
                f"{where} refer to missing entities {missing[:10].tolist()}"
                + (" ..." if missing.size > 10 else "")
            )
    return values.astype(np.int32)


def encode_labels(labels: npt.NDArray[np.int32]) -> EncodedLabels:
    raw = np.ascontiguousarray(labels, dtype=_DTYPE).tobytes()
    return EncodedLabels(
        count=int(labels.size),
        dtype=_DTYPE,
        codec=_CODEC,
        sha256=hashlib.sha256(raw).hexdigest(),
        data=zlib.compress(raw, 6),
    )


def decode_labels(encoded: EncodedLabels, scene_id: str) -> npt.NDArray[np.int32]:
    where = f"gaussian labels of scene {scene_id!r}"
    if encoded.codec != _CODEC or encoded.dtype != _DTYPE:
        raise GraphStoreError(f"{where}: unknown encoding {encoded.codec}/{encoded.dtype}")
    try:
        raw = zlib.decompress(encoded.data)
    except zlib.error as exc:
        raise GraphStoreError(f"{where} are corrupt: {exc}") from exc
    if hashlib.sha256(raw).hexdigest() != encoded.sha256:
        raise GraphStoreError(f"{where} are corrupt: checksum mismatch")
    array = np.frombuffer(raw, dtype=_DTYPE)
    if array.size != encoded.count:
        raise GraphStoreError(f"{where} are corrupt: {array.size} values, expected {encoded.count}")
    return array.astype(np.int32)
