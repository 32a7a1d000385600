"""Masks as people have them, read into :class:`MaskSet` and resampled to a camera's size.

Three forms other tools write, one file per image (the file's stem names the view):

* **SAM / SAM 2 automatic-mask-generator JSON** (``.json``): a list of annotations (or an
  object with an ``annotations`` list), each with a ``segmentation`` that is COCO RLE
  (``{"size": [h, w], "counts": "..."}``, compressed string or uncompressed list, as
  ``pycocotools`` writes it), a polygon list (``[[x0, y0, x1, y1, ...], ...]``) with the
  image size from the RLE-less annotation's ``size`` / the file's ``image`` entry, or a
  nested list of 0/1 rows. ``predicted_iou`` becomes the mask's score (else
  ``stability_score``); ``label`` / ``category`` / ``category_name`` its label when present.
* **Label maps** (``.png``, ``.npy`` of shape ``(H, W)``, integer): one mask per non-zero
  value, as Gaussian Grouping and LangSplat preprocessing write them. A ``.npy`` of shape
  ``(M, H, W)`` is a mask stack.
* **Mask stacks** (``.npz`` with ``masks`` of ``uint8`` 0/1 or 0/255, or ``bool``; optional
  ``labels`` and ``scores``).

Every mask is resampled to the camera's ``(height, width)`` by nearest neighbour (pixel
centres); an image where the tool found nothing is a mask set with no masks.

>>> decode_rle({"size": [2, 3], "counts": [1, 2, 3]}).astype(int).tolist()
[[0, 1, 0], [1, 0, 0]]
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from causalsplat._json import JSONInputError, decode_json
from causalsplat.masks.types import MaskFormatError, MaskSet

#: File suffixes :func:`read_mask_file` reads.
SUFFIXES = (".json", ".png", ".npy", ".npz")


def _counts_from_string(text: str) -> list[int]:
    """The run lengths of a compressed COCO RLE string (pycocotools' ``rleFrString``)."""
    counts: list[int] = []
    p = 0
    while p < len(text):
        x = k = 0
        more = True
        while more:
            if p >= len(text):
                raise ValueError("the RLE 'counts' string ends inside a run length")
            c = ord(text[p]) - 48
            if not 0 <= c < 64:
                raise ValueError(
                    f"the RLE 'counts' string holds {text[p]!r}, not a COCO RLE letter"
                )
            x |= (c & 0x1F) << (5 * k)
            more = bool(c & 0x20)
            p += 1
            k += 1
            if not more and c & 0x10:
                x |= -1 << (5 * k)
        if len(counts) > 2:
            x += counts[-2]
        counts.append(x)
    return counts


#: The longest image side a mask file may declare (as ``masks convert --size`` takes).
MAX_SIDE = 16_384


def _image_size(size: object, what: str) -> tuple[int, int]:
    """``[height, width]`` as two ints in ``[1, MAX_SIDE]``, else ValueError naming ``what``."""
    if not (
        isinstance(size, list) and len(size) == 2
        and all(isinstance(v, int) and not isinstance(v, bool) for v in size)
        and all(1 <= v <= MAX_SIDE for v in size)
    ):  # fmt: skip
        raise ValueError(f"{what} must be [height, width], each in [1, {MAX_SIDE}], got {size!r}")
    return size[0], size[1]


def decode_rle(rle: dict[str, Any]) -> np.ndarray:
    """A COCO RLE (column-major runs, first run of zeros) as an ``(h, w)`` bool mask."""
    size = rle.get("size")
    counts = rle.get("counts")
    h, w = _image_size(size, "RLE 'size'")
    if isinstance(counts, bytes):
        counts = counts.decode("ascii")
    runs = _counts_from_string(counts) if isinstance(counts, str) else counts
    if not isinstance(runs, list) or not all(isinstance(r, int) and r >= 0 for r in runs):
        raise ValueError("RLE 'counts' must be a string or a list of run lengths >= 0")
    if sum(runs) != h * w:
        raise ValueError(f"RLE runs cover {sum(runs)} pixels, the size {h}x{w} has {h * w}")
    values = np.zeros(len(runs), dtype=bool)
    values[1::2] = True
    flat = np.repeat(values, runs)
    return flat.reshape(w, h).T.copy()


def _polygons(polygons: Sequence[Sequence[float]], h: int, w: int) -> np.ndarray:
    """Pixels whose centre lies inside any polygon (even-odd rule)."""
    ys, xs = np.mgrid[0:h, 0:w]
    px, py = xs.ravel() + 0.5, ys.ravel() + 0.5
    out = np.zeros(h * w, dtype=bool)
    for poly in polygons:
        pts = np.asarray(poly, dtype=np.float64).reshape(-1, 2)
        inside = np.zeros(h * w, dtype=bool)
        for (x0, y0), (x1, y1) in zip(pts, np.roll(pts, -1, axis=0), strict=True):
            crosses = (y0 > py) != (y1 > py)
            with np.errstate(divide="ignore", invalid="ignore"):
                at = x0 + (py - y0) * (x1 - x0) / (y1 - y0)
            inside ^= crosses & (px < at)
        out |= inside
    return out.reshape(h, w)


def _annotation_mask(ann: dict[str, Any], size: tuple[int, int] | None) -> np.ndarray:
    seg = ann.get("segmentation")
    if isinstance(seg, dict):
        return decode_rle(seg)
    if isinstance(seg, list) and seg and isinstance(seg[0], list) and seg[0]:
        if isinstance(seg[0][0], bool) or (
            len(seg) > 1 and all(v in (0, 1) for v in seg[0]) and len(seg[0]) == len(seg[1])
        ):
            return np.asarray(seg, dtype=bool)  # a 0/1 bitmap
        hw = ann.get("size") or size
        if hw is None:
            raise ValueError("a polygon segmentation needs the image size ('size' or 'image')")
        return _polygons(seg, *_image_size(list(hw), "the polygon's image 'size'"))
    raise ValueError("'segmentation' must be COCO RLE, polygons or a 0/1 bitmap")


def read_sam_json(path: str | Path) -> MaskSet:
    """One image's annotations as SAM's automatic mask generator writes them (module doc)."""
    path = Path(path)
    try:
        document = decode_json(path.read_bytes())
    except JSONInputError as exc:
        raise MaskFormatError(f"{path}: {exc}") from None
    size: tuple[int, int] | None = None
    if isinstance(document, dict):
        image = document.get("image") or {}
        if isinstance(image, dict) and {"height", "width"} <= set(image):
            size = (int(image["height"]), int(image["width"]))
        document = document.get("annotations")
    if not isinstance(document, list):
        raise MaskFormatError(f"{path}: expected a list of annotations (SAM's JSON output)")
    masks, scores, labels = [], [], []
    for i, ann in enumerate(document):
        if not isinstance(ann, dict):
            raise MaskFormatError(f"{path}: annotation {i} is not an object")
        try:
            masks.append(_annotation_mask(ann, size))
        except ValueError as exc:
            raise MaskFormatError(f"{path}: annotation {i}: {exc}") from None
        score = ann.get("predicted_iou", ann.get("stability_score"))
        scores.append(float(score) if isinstance(score, int | float) else np.nan)
        label = next((ann[k] for k in ("label", "category_name", "category") if k in ann), None)
        labels.append(label if isinstance(label, str) else None)
    shapes = {m.shape for m in masks}
    if len(shapes) > 1:
        raise MaskFormatError(f"{path}: annotations of different image sizes {sorted(shapes)}")
    hw = shapes.pop() if shapes else (size or (1, 1))
    stack = np.stack(masks) if masks else np.zeros((0, *hw), dtype=bool)
    return MaskSet(
        view=path.stem,
        masks=stack,
        labels=tuple(labels) if masks and all(lab is not None for lab in labels) else None,
        scores=np.asarray(scores, np.float32) if masks and not np.isnan(scores).any() else None,
    )


def _from_label_map(view: str, labels: np.ndarray) -> MaskSet:
    ids = np.unique(labels)
    ids = ids[ids != 0]
    stack = labels[None, :, :] == ids[:, None, None]
    return MaskSet(view=view, masks=stack)


def _from_stack(view: str, stack: np.ndarray, where: Path) -> np.ndarray:
    if stack.dtype == np.bool_:
        return stack
    if stack.dtype.kind not in "iu":
        raise MaskFormatError(f"{where}: masks of dtype {stack.dtype}; expected bool or integer")
    values = np.unique(stack)
    if not set(values.tolist()) <= {0, 1, 255}:
        raise MaskFormatError(f"{where}: a mask stack holds values {values[:6].tolist()}...;"
                              " expected 0/1 or 0/255")  # fmt: skip
    return stack > 0


def read_mask_file(path: str | Path) -> MaskSet:
    """Any of the module docstring's forms, by suffix."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".json":
        return read_sam_json(path)
    try:
        if suffix == ".png":
            from PIL import Image

            with Image.open(path) as image:
                array = np.asarray(image)
        elif suffix == ".npy":
            array = np.load(path, allow_pickle=False)
        elif suffix == ".npz":
            with np.load(path, allow_pickle=False) as data:
                if "masks" not in data:
                    raise MaskFormatError(f"{path}: no 'masks' array")
                stack = _from_stack(path.stem, np.asarray(data["masks"]), path)
                labels = tuple(str(v) for v in data["labels"]) if "labels" in data else None
                scores = np.asarray(data["scores"]) if "scores" in data else None
                if stack.ndim != 3:
                    raise MaskFormatError(f"{path}: masks of shape {stack.shape}; expected 3-D")
                return MaskSet(view=path.stem, masks=stack, labels=labels, scores=scores)
        else:
            raise MaskFormatError(f"{path}: unknown mask file type (read: {', '.join(SUFFIXES)})")
    except (OSError, ValueError) as exc:
        if isinstance(exc, MaskFormatError):
            raise
        raise MaskFormatError(f"{path}: cannot read masks: {exc}") from None
    if array.ndim == 2 and array.dtype.kind in "iu":
        return _from_label_map(path.stem, array)
    if array.ndim == 3 and suffix == ".npy":
        return MaskSet(view=path.stem, masks=_from_stack(path.stem, array, path))
    raise MaskFormatError(
        f"{path}: an array of shape {array.shape} and dtype {array.dtype}; expected an (H, W)"
        " integer label map or an (M, H, W) mask stack"
    )


def resample(maskset: MaskSet, height: int, width: int) -> MaskSet:
    """The masks on a ``height`` x ``width`` grid, nearest pixel centre (no change when
    the size is already that)."""
    m, h, w = maskset.masks.shape
    if (h, w) == (height, width):
        return maskset
    rows = np.minimum(((np.arange(height) + 0.5) * h / height).astype(np.int64), h - 1)
    cols = np.minimum(((np.arange(width) + 0.5) * w / width).astype(np.int64), w - 1)
    masks = maskset.masks[:, rows[:, None], cols[None, :]]
    return MaskSet(view=maskset.view, masks=masks.reshape(m, height, width),
                   labels=maskset.labels, scores=maskset.scores, ids=maskset.ids)  # fmt: skip


@dataclass(frozen=True, slots=True)
class ConvertReport:
    """What :func:`convert_masks` wrote."""

    views: int
    masks: int
    labelled_views: int
    resampled_views: int
    output: str

    def to_json(self) -> dict[str, Any]:
        return {"views": self.views, "masks": self.masks, "labelled_views": self.labelled_views,
                "resampled_views": self.resampled_views, "output": self.output}  # fmt: skip


def convert_masks(
    source: str | Path,
    output: str | Path,
    *,
    sizes: Mapping[str, tuple[int, int]] | None = None,
    size: tuple[int, int] | None = None,
) -> ConvertReport:
    """Write every mask file of ``source`` (module docstring) as ``output/<stem>.npz``.

    ``sizes``: the ``(height, width)`` of each view by image stem (a scene folder's
    cameras); a file whose stem has no camera is refused. ``size``: one size for all.
    Without either, masks keep their own size. Nothing is written when any file fails.
    """
    from causalsplat.masks.files import view_files, write_masks

    source, output = Path(source), Path(output)
    files = view_files(source, SUFFIXES, what="mask files", each="files", error=MaskFormatError)
    converted = []
    resampled = 0
    for path in files:
        maskset = read_mask_file(path)
        target = size
        if sizes is not None:
            if path.stem not in sizes:
                raise MaskFormatError(f"{path}: no camera for view {path.stem!r}")
            target = sizes[path.stem]
        if target is not None and maskset.masks.shape[1:] != tuple(target):
            maskset = resample(maskset, *target)
            resampled += 1
        converted.append(maskset)
    output.mkdir(parents=True, exist_ok=True)
    for maskset in converted:
        write_masks(output / f"{maskset.view}.npz", maskset)
    return ConvertReport(
        views=len(converted),
        masks=sum(m.masks.shape[0] for m in converted),
        labelled_views=sum(m.labels is not None for m in converted),
        resampled_views=resampled,
        output=str(output),
    )
