"""Compact per-Gaussian entity labels.

A built scene keeps, for each of its N Gaussians, the local id of the entity it belongs
to (``-1``: none). That array is what turns a persisted answer back into a 3D mask (and,
through the renderer, 2D masks) without retraining. It is stored as one row per scene:
little-endian int32, zlib-compressed, with its length and SHA-256 checked on load.
:func:`decode_labels` reads such a blob back (from any client: see ``docs/store.md``).
"""

from __future__ import annotations

import hashlib
import zlib
from collections.abc import Collection
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from graph_store.errors import GraphStoreError, InvalidSceneError

#: How the array is stored: little-endian int32, compressed with zlib.
DTYPE = "<i4"
CODEC = "zlib"


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
    raw = np.ascontiguousarray(labels, dtype=DTYPE).tobytes()
    return EncodedLabels(
        count=int(labels.size),
        dtype=DTYPE,
        codec=CODEC,
        sha256=hashlib.sha256(raw).hexdigest(),
        data=zlib.compress(raw, 6),
    )


def decode_labels(
    data: bytes | bytearray | memoryview,
    *,
    count: int | None = None,
    sha256: str | None = None,
    dtype: str = DTYPE,
    codec: str = CODEC,
) -> npt.NDArray[np.int32]:
    """The ``(N,)`` int32 entity id per Gaussian (``-1``: none) from a stored labels blob.

    ``data`` is the ``gaussian_labels.data`` column of a row as any client returns it
    (``bytes`` from ``sqlite3``, ``memoryview``/``bytes`` from psycopg); ``count``,
    ``sha256``, ``dtype`` and ``codec`` are the row's other columns: when given, they are
    checked. Raises :class:`~graph_store.errors.GraphStoreError` for an unknown encoding or
    a corrupt blob.

    >>> import zlib
    >>> blob = zlib.compress(np.array([-1, 4, 4, 7], dtype="<i4").tobytes())
    >>> decode_labels(blob, count=4)
    array([-1,  4,  4,  7], dtype=int32)
    >>> decode_labels(blob, count=5)
    Traceback (most recent call last):
    ...
    graph_store.errors.GraphStoreError: gaussian labels are corrupt: 4 values, expected 5
    """
    where = "gaussian labels"
    if codec != CODEC or dtype != DTYPE:
        raise GraphStoreError(f"{where}: unknown encoding {codec}/{dtype}")
    try:
        raw = zlib.decompress(bytes(data))
    except zlib.error as exc:
        raise GraphStoreError(f"{where} are corrupt: {exc}") from exc
    if sha256 is not None and hashlib.sha256(raw).hexdigest() != sha256:
        raise GraphStoreError(f"{where} are corrupt: checksum mismatch")
    if len(raw) % 4:
        raise GraphStoreError(f"{where} are corrupt: {len(raw)} bytes is no whole int32 array")
    array = np.frombuffer(raw, dtype=DTYPE)
    if count is not None and array.size != count:
        raise GraphStoreError(f"{where} are corrupt: {array.size} values, expected {count}")
    return array.astype(np.int32)


def decode_row(encoded: EncodedLabels, scene_id: str) -> npt.NDArray[np.int32]:
    """:func:`decode_labels` of a stored row, with the scene named in any error."""
    try:
        return decode_labels(
            encoded.data,
            count=encoded.count,
            sha256=encoded.sha256,
            dtype=encoded.dtype,
            codec=encoded.codec,
        )
    except GraphStoreError as exc:
        message = str(exc).replace("gaussian labels", f"gaussian labels of scene {scene_id!r}", 1)
        raise GraphStoreError(message) from exc
