"""Binary masks as compressed COCO RLE, the form SAM's automatic mask generator writes.

A COCO RLE holds the run lengths of a mask read column by column (column-major), starting
with a run of zeros (of length 0 when the first pixel is set). The compressed string form
stores each run, less the run two places before it from the fourth run on, in groups of
5 bits per character (offset by 48, bit 0x20 meaning "more groups follow"), as
``pycocotools`` does; :func:`~causalsplat.masks.convert.decode_rle` reads it back.

>>> import numpy as np
>>> from causalsplat.masks.convert import decode_rle
>>> mask = np.array([[0, 1, 1], [1, 1, 0]], dtype=bool)
>>> mask_runs(mask)  # 0 1 | 1 1 | 1 0, read down each column
[1, 4, 1]
>>> rle = encode_rle(mask)
>>> rle
{'size': [2, 3], 'counts': '141'}
>>> bool((decode_rle(rle) == mask).all())
True
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np


def mask_runs(mask: np.ndarray) -> list[int]:
    """The run lengths of an ``(h, w)`` mask in column-major order, zeros first."""
    flat = np.asarray(mask, dtype=bool).ravel(order="F")
    if flat.size == 0:
        return []
    changes = np.flatnonzero(flat[1:] != flat[:-1]) + 1
    runs = np.diff(np.concatenate(([0], changes, [flat.size]))).tolist()
    return [0, *runs] if flat[0] else runs


def counts_to_string(runs: Sequence[int]) -> str:
    """Run lengths as a compressed COCO RLE string (the inverse of the reader's
    ``_counts_from_string``)."""
    chars: list[str] = []
    for i, run in enumerate(runs):
        x = int(run) - (int(runs[i - 2]) if i > 2 else 0)
        more = True
        while more:
            c = x & 0x1F
            x >>= 5  # arithmetic shift: a negative difference ends at -1
            more = x != -1 if c & 0x10 else x != 0
            chars.append(chr(48 + (c | 0x20 if more else c)))
    return "".join(chars)


def encode_rle(mask: np.ndarray) -> dict[str, object]:
    """An ``(h, w)`` mask as ``{"size": [h, w], "counts": str}`` (compressed COCO RLE)."""
    array = np.asarray(mask)
    if array.ndim != 2:
        raise ValueError(f"a mask to encode must be (h, w), got shape {array.shape}")
    h, w = array.shape
    return {"size": [int(h), int(w)], "counts": counts_to_string(mask_runs(array))}
