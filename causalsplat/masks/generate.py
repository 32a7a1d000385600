"""Masks made here: SAM's (or SAM 2's) automatic mask generator over a folder of images.

:func:`generate_masks` reads every ``.png`` / ``.jpg`` / ``.jpeg`` image of a folder (sorted;
the file's stem names the view; pixels as stored, no EXIF rotation), runs the automatic mask
generator of the model the user's checkpoint holds, on the CPU unless told otherwise, and
writes ``<stem>.json`` per image in the form of SAM's ``amg.py --convert-to-rle``: a list of
annotations ``{"segmentation": {"size": [h, w], "counts": str}, "area", "bbox": [x, y, w, h],
"predicted_iou", "point_coords", "stability_score", "crop_box"}``, the segmentation as
compressed COCO RLE (:mod:`causalsplat.masks.rle`). ``masks convert`` reads that folder
(:mod:`causalsplat.masks.convert`).

Nothing is downloaded: the weights are the checkpoint file given. The model's package
(``segment-anything`` for SAM, ``sam2`` for SAM 2) and torch are imported when the function
runs, never when this module is. Every input is checked before the model is loaded (model
name, options, checkpoint file, images, output folder), and the checkpoint's weights are
checked against the model before any image is segmented; a refused input raises
:class:`MaskGenerateError` and writes nothing.
"""

from __future__ import annotations

import importlib.util
import json
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from causalsplat._atomic import atomic_target
from causalsplat.errors import InputFormatError, MissingDependencyError

#: Image suffixes read (any case).
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg")
#: SAM's model names (``segment_anything.sam_model_registry``), smallest first.
SAM_MODELS = ("vit_b", "vit_l", "vit_h")
#: SAM 2's model names and the config of ``sam2`` that builds each, smallest first.
SAM2_CONFIGS = {
    f"{version}_hiera_{size}": f"configs/{version}/{version}_hiera_{size}.yaml"
    for version in ("sam2.1", "sam2")
    for size in ("t", "s", "b+", "l")
}
#: Every model name :func:`generate_masks` takes.
MODELS = (*SAM_MODELS, *SAM2_CONFIGS)


class MaskGenerateError(InputFormatError):
    """An input of :func:`generate_masks` is refused: the model name, an option, the images
    or the output folder. The message names the value and what is allowed."""


class CheckpointError(MaskGenerateError):
    """The checkpoint is missing or unreadable, or its weights do not fit the chosen model."""


#: name -> (type, lowest, highest or None for no bound) of each option.
_RANGES: dict[str, tuple[type, float, float | None]] = {
    "points_per_side": (int, 1, 256),
    "points_per_batch": (int, 1, 4096),
    "pred_iou_thresh": (float, 0.0, 1.0),
    "stability_score_thresh": (float, 0.0, 1.0),
    "box_nms_thresh": (float, 0.0, 1.0),
    "crop_n_layers": (int, 0, 4),
    "min_mask_region_area": (int, 0, None),
}


@dataclass(frozen=True, slots=True)
class GenerateConfig:
    """Options of the automatic mask generator (SAM's defaults).

    Attributes:
        points_per_side: the prompt grid has this many points per side (``n²`` prompts
            per image and crop layer; time grows with it).
        points_per_batch: prompts run through the mask decoder at once (memory only).
        pred_iou_thresh: masks whose predicted IoU is below this are dropped, in [0, 1].
        stability_score_thresh: masks less stable than this under a shifted threshold
            are dropped, in [0, 1].
        box_nms_thresh: masks whose boxes overlap a better one's by more than this IoU
            are dropped, in [0, 1].
        crop_n_layers: also segment ``2^k x 2^k`` crops for k = 1..n (slower).
        min_mask_region_area: px; holes and islands smaller than this are removed from
            each mask (needs OpenCV when > 0).
    """

    points_per_side: int = 32
    points_per_batch: int = 64
    pred_iou_thresh: float = 0.88
    stability_score_thresh: float = 0.95
    box_nms_thresh: float = 0.7
    crop_n_layers: int = 0
    min_mask_region_area: int = 0

    def __post_init__(self) -> None:
        for name, (kind, low, high) in _RANGES.items():
            value = getattr(self, name)
            numeric = isinstance(value, int | float) and not isinstance(value, bool)
            if kind is int:
                ok = numeric and isinstance(value, int)
                what = "an integer"
            else:
                ok = numeric and bool(np.isfinite(value))
                what = "a number"
            ok = ok and low <= value and (high is None or value <= high)
            if not ok:
                allowed = f">= {low}" if high is None else f"in [{low}, {high}]"
                raise MaskGenerateError(f"{name}={value!r} must be {what} {allowed}")


@dataclass(frozen=True, slots=True)
class ImageDone:
    """One image segmented and its JSON written (what ``progress`` receives).

    Attributes:
        index: 1-based position of the image; total: number of images.
        image: the image's path; masks: how many masks it got; seconds: wall time.
    """

    index: int
    total: int
    image: str
    masks: int
    seconds: float


@dataclass(frozen=True, slots=True)
class GenerateReport:
    """What :func:`generate_masks` wrote: ``views`` JSON files holding ``masks`` masks in
    all to ``output``, made by ``model`` on ``device`` in ``seconds`` (wall time, model
    loading included)."""

    views: int
    masks: int
    output: str
    model: str
    device: str
    seconds: float

    def to_json(self) -> dict[str, Any]:
        return asdict(self)


def _require_packages(model: str, config: GenerateConfig) -> None:
    sam2 = model in SAM2_CONFIGS
    wanted = {"torch": "torch", "PIL": "field"}
    wanted["sam2" if sam2 else "segment_anything"] = "sam2" if sam2 else "sam"
    missing = [name for name in wanted if importlib.util.find_spec(name) is None]
    if missing:
        extras = ",".join(sorted({wanted[name] for name in missing}))
        raise MissingDependencyError(
            f"masks generate with {model} needs {', '.join(missing)}: "
            f"pip install 'causalsplat[{extras}]'"
        )
    if config.min_mask_region_area > 0 and importlib.util.find_spec("cv2") is None:
        raise MissingDependencyError(
            "min_mask_region_area > 0 needs OpenCV: pip install opencv-python-headless"
        )


def _check_checkpoint(path: Path) -> Path:
    if not path.is_file():
        what = "is a folder" if path.is_dir() else "does not exist"
        raise CheckpointError(f"checkpoint {path} {what}: give the model's weights file")
    try:
        with path.open("rb") as handle:
            handle.read(1)
    except OSError as exc:
        raise CheckpointError(f"checkpoint {path} cannot be read: {exc.strerror}") from exc
    return path


def list_images(folder: str | Path) -> list[Path]:
    """The images of ``folder`` (:data:`IMAGE_SUFFIXES`), sorted by name; refuses a
    folder without images and two images of one stem."""
    from causalsplat.masks.files import view_files

    return view_files(Path(folder), IMAGE_SUFFIXES, what="images", each="images",
                      error=MaskGenerateError)  # fmt: skip


def read_image(path: Path) -> np.ndarray:
    """An image as an ``(H, W, 3)`` uint8 RGB array (what SAM takes)."""
    from PIL import Image

    try:
        with Image.open(path) as image:
            return np.asarray(image.convert("RGB"), dtype=np.uint8)
    except (OSError, ValueError, Image.DecompressionBombError) as exc:
        raise MaskGenerateError(f"{path}: cannot read the image: {exc}") from exc


def _check_output(output: Path) -> Path:
    if output.exists() and not output.is_dir():
        raise MaskGenerateError(f"output {output} exists and is not a folder")
    return output


def _write_json(path: Path, document: Any) -> None:
    with atomic_target(path) as tmp:
        tmp.write_text(json.dumps(document), encoding="utf-8")


def generate_masks(
    images: str | Path,
    output: str | Path,
    checkpoint: str | Path,
    *,
    model: str = "vit_b",
    config: GenerateConfig | None = None,
    device: str = "cpu",
    progress: Callable[[ImageDone], None] | None = None,
) -> GenerateReport:
    """Segment every image of ``images`` and write ``output/<stem>.json`` (module doc).

    ``model``: one of :data:`MODELS`, the architecture of ``checkpoint`` (SAM's
    ``sam_vit_b_01ec64.pth`` is ``vit_b``; SAM 2's ``sam2.1_hiera_tiny.pt`` is
    ``sam2.1_hiera_t``). ``device``: a torch device (``cpu``, ``cuda``, ``cuda:1``...).
    ``progress`` is called after each image. Raises :class:`MaskGenerateError` (or its
    :class:`CheckpointError`) for a refused input, :class:`MissingDependencyError` when
    torch, pillow or the model's package is not installed.
    """
    config = GenerateConfig() if config is None else config
    if model not in MODELS:
        raise MaskGenerateError(f"unknown model {model!r}; known: {', '.join(MODELS)}")
    _require_packages(model, config)
    checkpoint = _check_checkpoint(Path(checkpoint))
    files = list_images(images)
    output = _check_output(Path(output))
    for path in files:  # every image readable before the model is loaded
        read_image(path)

    from causalsplat.masks._sam_runner import load_generator

    start = time.perf_counter()
    generate = load_generator(model, checkpoint, config, device)
    output.mkdir(parents=True, exist_ok=True)
    total = 0
    for index, path in enumerate(files, start=1):
        began = time.perf_counter()
        annotations = generate(read_image(path))
        _write_json(output / f"{path.stem}.json", annotations)
        total += len(annotations)
        if progress is not None:
            done = time.perf_counter() - began
            progress(ImageDone(index, len(files), str(path), len(annotations), done))
    return GenerateReport(
        views=len(files),
        masks=total,
        output=str(output),
        model=model,
        device=device,
        seconds=round(time.perf_counter() - start, 3),
    )
