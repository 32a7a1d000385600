"""Masks as SAM, Gaussian Grouping and LangSplat users have them, through ``masks convert``.

COCO RLE is encoded by pycocotools, the library SAM's automatic mask generator writes it
with (``segment_anything.utils.amg.coco_encode_rle``); the files are laid out as SAM's
``amg.py --convert-to-rle`` writes them (one JSON list of annotations per image).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from causalsplat.masks.convert import convert_masks, decode_rle, read_mask_file, resample
from causalsplat.masks.files import read_masks
from causalsplat.masks.types import MaskFormatError
from tests.causalsplat.test_cli_store import assert_one_line_error, run

mask_utils = pytest.importorskip("pycocotools.mask")
pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")  # pycocotools on numpy 2


def _sam_annotation(mask: np.ndarray, iou: float) -> dict[str, object]:
    rle = mask_utils.encode(np.asfortranarray(mask.astype(np.uint8)))
    rle["counts"] = rle["counts"].decode("utf-8")  # as SAM's coco_encode_rle does
    ys, xs = np.nonzero(mask)
    return {
        "segmentation": rle,
        "area": int(mask.sum()),
        "bbox": [int(xs.min()), int(ys.min()), int(np.ptp(xs) + 1), int(np.ptp(ys) + 1)],
        "predicted_iou": iou,
        "point_coords": [[float(xs.mean()), float(ys.mean())]],
        "stability_score": 0.97,
        "crop_box": [0, 0, mask.shape[1], mask.shape[0]],
    }


def _random_masks(rng: np.random.Generator, m: int, h: int, w: int) -> np.ndarray:
    masks = np.zeros((m, h, w), dtype=bool)
    for i in range(m):
        y0, x0 = rng.integers(0, h - 4), rng.integers(0, w - 4)
        masks[i, y0 : y0 + rng.integers(2, h - y0), x0 : x0 + rng.integers(2, w - x0)] = True
        masks[i] ^= rng.random((h, w)) < 0.05  # ragged edges: many runs
    return masks


def test_rle_decodes_as_pycocotools_encodes() -> None:
    rng = np.random.default_rng(0)
    for h, w in ((1, 1), (7, 3), (48, 64), (97, 131)):
        for mask in _random_masks(rng, 3, max(h, 5), max(w, 5)):
            rle = mask_utils.encode(np.asfortranarray(mask.astype(np.uint8)))
            assert np.array_equal(decode_rle({**rle, "counts": rle["counts"].decode()}), mask)
            assert np.array_equal(mask_utils.decode(rle).astype(bool), mask)
    full = np.ones((5, 4), dtype=bool)
    rle = mask_utils.encode(np.asfortranarray(full.astype(np.uint8)))
    assert decode_rle({**rle, "counts": rle["counts"].decode()}).all()
    with pytest.raises(ValueError, match="cover 5 pixels"):
        decode_rle({"size": [2, 3], "counts": [1, 4]})


def test_sam_json_label_maps_and_stacks_convert_to_camera_size(tmp_path: Path) -> None:
    rng = np.random.default_rng(1)
    src = tmp_path / "sam"
    src.mkdir()
    masks = _random_masks(rng, 4, 60, 80)
    ious = [0.91, 0.88, 0.95, 0.79]
    (src / "frame_000.json").write_text(
        json.dumps([_sam_annotation(m, iou) for m, iou in zip(masks, ious, strict=True)])
    )
    (src / "frame_001.json").write_text("[]")  # SAM found nothing in this view
    label_map = np.zeros((30, 40), dtype=np.uint16)
    label_map[2:10, 3:20], label_map[15:28, 5:9] = 7, 300
    Image.fromarray(label_map).save(src / "frame_002.png")
    np.savez(src / "frame_003.npz", masks=(masks[:2] * 255).astype(np.uint8))
    sizes = {f"frame_00{i}": (120, 160) for i in range(4)}

    report = convert_masks(src, tmp_path / "out", sizes=sizes)
    assert (report.views, report.masks, report.resampled_views) == (4, 4 + 0 + 2 + 2, 4)
    first = read_masks(tmp_path / "out" / "frame_000.npz")
    assert first.masks.shape == (4, 120, 160) and first.labels is None
    assert np.allclose(first.scores, ious)
    assert np.array_equal(first.masks[:, ::2, ::2], masks)  # nearest pixel centre, 2x
    assert read_masks(tmp_path / "out" / "frame_001.npz").masks.shape == (0, 120, 160)
    maps = read_masks(tmp_path / "out" / "frame_002.npz").masks
    assert maps.shape == (2, 120, 160) and maps[0, 8:40, 12:80].all() and not maps[0].all()
    assert np.array_equal(read_masks(tmp_path / "out" / "frame_003.npz").masks[:, ::2, ::2],
                          masks[:2])  # fmt: skip


def test_polygons_and_labels(tmp_path: Path) -> None:
    path = tmp_path / "v.json"
    path.write_text(json.dumps({"image": {"height": 10, "width": 10}, "annotations": [
        {"segmentation": [[2, 2, 8, 2, 8, 6, 2, 6]], "label": "table", "predicted_iou": 0.9},
    ]}))  # fmt: skip
    read = read_mask_file(path)
    assert read.labels == ("table",) and read.masks.shape == (1, 10, 10)
    expected = np.zeros((10, 10), dtype=bool)
    expected[2:6, 2:8] = True  # pixel centres inside the rectangle
    assert np.array_equal(read.masks[0], expected)
    assert resample(read, 10, 10) is read


def test_bad_mask_files_are_one_line(tmp_path: Path) -> None:
    src = tmp_path / "bad"
    src.mkdir()
    (src / "a.json").write_text('[{"segmentation": {"size": [2, 2], "counts": [1, 9]}}]')
    with pytest.raises(MaskFormatError, match=r"a.json: annotation 0: RLE runs cover 10"):
        convert_masks(src, tmp_path / "out")
    assert not (tmp_path / "out").exists()  # nothing written when a file fails
    proc = run("masks", "convert", str(src), "-o", str(tmp_path / "out"), check=False)
    assert_one_line_error(proc, "RLE runs cover 10 pixels")
    (src / "a.json").write_text("[]")
    np.save(src / "b.npy", np.full((4, 4), 0.5))
    assert_one_line_error(run("masks", "convert", str(src), "-o", str(tmp_path / "out"),
                              check=False), "expected an (H, W) integer label map")  # fmt: skip
    (src / "b.npy").unlink()
    proc = run("masks", "convert", str(src), "-o", str(tmp_path / "out"), "--size", "8x6",
               "--json")  # fmt: skip
    assert json.loads(proc.stdout)["views"] == 1
    assert read_masks(tmp_path / "out" / "a.npz").masks.shape == (0, 6, 8)
    assert_one_line_error(run("masks", "convert", str(src), "-o", str(tmp_path / "o"),
                              "--size", "0x6", check=False), "WIDTHxHEIGHT")  # fmt: skip


@pytest.mark.parametrize(
    ("segmentation", "words"),
    [
        ({"size": [2, 2], "counts": "P"}, "ends inside a run length"),  # "more digits" bit, cut
        ({"size": [2, 2], "counts": "~~"}, "not a COCO RLE letter"),
        ({"size": [100000, 100000], "counts": [10**10]}, "each in [1, 16384]"),
        ({"size": [2], "counts": [4]}, "must be [height, width]"),
        ([[0, 0, 1, 0, 1, 1]], "image 'size' must be [height, width]"),
    ],
)
def test_bad_coco_segmentations_are_one_line(
    tmp_path: Path, segmentation: object, words: str
) -> None:
    src = tmp_path / "bad"
    src.mkdir()
    ann = {"segmentation": segmentation}
    if isinstance(segmentation, list):
        ann["size"] = [5]  # a polygon with a one-number image size
    (src / "a.json").write_text(json.dumps([ann]))
    proc = run("masks", "convert", str(src), "-o", str(tmp_path / "out"), check=False)
    assert_one_line_error(proc, words)
    assert not (tmp_path / "out").exists()
