"""The COCO RLE encoder against pycocotools, the library SAM writes its RLE with."""

from __future__ import annotations

import numpy as np
import pytest

from causalsplat.masks.convert import decode_rle
from causalsplat.masks.rle import counts_to_string, encode_rle, mask_runs

mask_utils = pytest.importorskip("pycocotools.mask")
pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")  # pycocotools on numpy 2


def _masks(rng: np.random.Generator, h: int, w: int) -> list[np.ndarray]:
    empty, full = np.zeros((h, w), dtype=bool), np.ones((h, w), dtype=bool)
    corner = empty.copy()
    corner[0, 0] = True  # the first run of zeros is empty
    last = empty.copy()
    last[-1, -1] = True
    blob = empty.copy()
    blob[h // 4 : 3 * h // 4 + 1, w // 3 : w - 1] = True
    noisy = [rng.random((h, w)) < p for p in (0.02, 0.5, 0.97)]
    return [empty, full, corner, last, blob, blob ^ noisy[0], *noisy]


@pytest.mark.parametrize("shape", [(1, 1), (1, 7), (6, 1), (2, 3), (48, 64), (97, 131)])
def test_encode_rle_writes_what_pycocotools_writes(shape: tuple[int, int]) -> None:
    rng = np.random.default_rng(shape[0] * 1000 + shape[1])
    for mask in _masks(rng, *shape):
        ours = encode_rle(mask)
        theirs = mask_utils.encode(np.asfortranarray(mask.astype(np.uint8)))
        assert ours == {"size": list(theirs["size"]), "counts": theirs["counts"].decode()}
        assert np.array_equal(decode_rle(ours), mask)
        assert sum(mask_runs(mask)) == mask.size


def test_long_runs_and_large_differences() -> None:
    """Runs of 2**20 pixels and differences of both signs need several 5-bit groups."""
    mask = np.zeros((1024, 1536), dtype=bool)
    mask[:, 700:] = True
    mask[5:9, 1000] = False
    theirs = mask_utils.encode(np.asfortranarray(mask.astype(np.uint8)))
    assert encode_rle(mask)["counts"] == theirs["counts"].decode()
    assert counts_to_string([]) == ""


def test_encode_rle_refuses_a_stack() -> None:
    with pytest.raises(ValueError, match=r"must be \(h, w\), got shape \(2, 3, 4\)"):
        encode_rle(np.zeros((2, 3, 4), dtype=bool))
