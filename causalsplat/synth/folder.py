"""Writing a scene folder in the DESIGN §9 build-input layout, deterministically and atomically.

Layout (``<stem>`` is a view's image stem)::

    point_cloud.ply          3DGS PLY with a ``gt_instance`` property (GT entity, -1 none)
    sparse/0/*.txt           COLMAP text model: one PINHOLE camera per image
    images/<stem>.png        rendered (or real) RGB
    masks/<stem>.npz         masks the build reads (noisy; labels = category names)
    gt/masks/<stem>.npz      exact instance masks from the id render (with ``ids``)
    gt/gt_labels.npy         (N,) int32 GT entity id per Gaussian (-1 none)
    gt/scene.json            how the scene was made (parameters, counts, entities)
    objects.json             GT objects (DESIGN §9 objects input)
    queries.json             queries with GT targets (DESIGN §9 queries file)

Cameras (COLMAP, and so OpenCV world-to-camera, like :class:`~causalsplat.io.types.Camera`)
are named ``<stem>.png``, relative to ``images/``. Nothing depends on the clock: the same
inputs give the same bytes. The folder is assembled under a hidden sibling and renamed into
place at the end, so a failure leaves nothing half-written.
"""

from __future__ import annotations

import json
import os
import shutil
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from causalsplat.errors import CausalSplatError
from causalsplat.io.types import Camera, GaussianScene
from causalsplat.masks import MaskSet, write_masks

#: The PLY vertex property holding the instance each Gaussian was generated from: the
#: generator's ground truth, not an entity of any build (docs/formats.md).
GT_PROPERTY = "gt_instance"
GT_COMMENTS = (
    "gt_instance: ground-truth instance of each Gaussian (-1 none), from the generator;"
    " not a built entity",
)


class SceneFolderError(CausalSplatError):
    """The output folder cannot be created, or exists and holds something else."""


@dataclass(frozen=True, slots=True)
class SceneFolderContent:
    """Everything a scene folder holds (the arrays and documents to write).

    Attributes:
        gaussians: the Gaussian scene.
        labels: (N,) int GT entity id per Gaussian, -1 none.
        cameras: one camera per view; ``name`` is the image stem.
        images: (V, H, W, 3) uint8 RGB, one per camera.
        masks: per view, the masks written to ``masks/``.
        gt_masks: per view, the exact masks written to ``gt/masks/``.
        objects: the ``objects.json`` document.
        queries: the ``queries.json`` document.
        scene_info: the ``gt/scene.json`` document.
        extra_pngs: further (H, W, 3) uint8 images, by path relative to the folder.
    """

    gaussians: GaussianScene
    labels: np.ndarray
    cameras: tuple[Camera, ...]
    images: np.ndarray
    masks: tuple[MaskSet, ...]
    gt_masks: tuple[MaskSet, ...]
    objects: dict[str, Any]
    queries: dict[str, Any]
    scene_info: dict[str, Any]
    extra_pngs: tuple[tuple[str, np.ndarray], ...] = ()


def _is_scene_folder(path: Path) -> bool:
    return (path / "gt" / "scene.json").is_file()


def check_output_dir(out_dir: str | Path, *, overwrite: bool = False) -> Path:
    """Validate ``out_dir`` before any work: absent, empty, or (with ``overwrite``) a scene folder.

    Returns the absolute path. Raises :class:`SceneFolderError` otherwise.
    """
    out = Path(out_dir).absolute()
    if out.exists() and not out.is_dir():
        raise SceneFolderError(f"output {out} exists and is not a folder")
    if out.is_dir() and any(out.iterdir()):
        if not overwrite:
            raise SceneFolderError(f"output folder {out} is not empty (use --overwrite)")
        if not _is_scene_folder(out):
            raise SceneFolderError(
                f"output folder {out} is not empty and is not a scene folder; not replacing it"
            )
    parent = out.parent
    if parent.exists() and not parent.is_dir():
        raise SceneFolderError(f"cannot create {out}: {parent} is not a folder")
    return out


def write_json(path: Path, document: Any) -> None:
    """Write ``document`` as indented UTF-8 JSON with a trailing newline."""
    path.write_text(json.dumps(document, indent=2, ensure_ascii=False) + "\n", encoding="utf-8")


def write_png(path: Path, image: np.ndarray) -> None:
    """Write a (H, W, 3) uint8 image as PNG (no timestamps, fixed compression)."""
    from PIL import Image

    Image.fromarray(np.ascontiguousarray(image, dtype=np.uint8), mode="RGB").save(
        path, format="PNG", compress_level=6
    )


def write_cameras(sparse_dir: Path, cameras: Sequence[Camera]) -> None:
    """A COLMAP text model of ``cameras``, image names ``<stem>.png``."""
    from causalsplat.io import ColmapModel, ColmapPoints, write_colmap_model

    named = tuple(
        Camera(f"{c.name}.png", c.width, c.height, c.fx, c.fy, c.cx, c.cy, c.T_cam_world)
        for c in cameras
    )
    model = ColmapModel(
        cameras=named, image_ids=tuple(range(1, len(named) + 1)), points=ColmapPoints.empty()
    )
    write_colmap_model(sparse_dir, model, binary=False)


def _write_all(root: Path, content: SceneFolderContent) -> None:
    from causalsplat.io import write_ply

    for sub in ("images", "masks", "gt/masks", "sparse/0"):
        (root / sub).mkdir(parents=True)
    labels = np.asarray(content.labels, dtype=np.int32)
    write_ply(root / "point_cloud.ply", content.gaussians, extra={GT_PROPERTY: labels},
              comments=GT_COMMENTS)  # fmt: skip
    write_cameras(root / "sparse" / "0", content.cameras)
    views = zip(content.cameras, content.images, content.masks, content.gt_masks, strict=True)
    for cam, image, masks, gt in views:
        write_png(root / "images" / f"{cam.name}.png", image)
        write_masks(root / "masks" / f"{cam.name}.npz", masks)
        write_masks(root / "gt" / "masks" / f"{cam.name}.npz", gt)
    with open(root / "gt" / "gt_labels.npy", "wb") as fh:
        np.save(fh, labels, allow_pickle=False)
    write_json(root / "gt" / "scene.json", content.scene_info)
    write_json(root / "objects.json", content.objects)
    write_json(root / "queries.json", content.queries)
    for rel, image in content.extra_pngs:
        target = root / rel
        target.parent.mkdir(parents=True, exist_ok=True)
        write_png(target, image)


def write_scene_folder(
    out_dir: str | Path, content: SceneFolderContent, *, overwrite: bool = False
) -> Path:
    """Write ``content`` to ``out_dir`` (module docstring); returns the folder's path."""
    out = check_output_dir(out_dir, overwrite=overwrite)
    tmp = out.parent / f".{out.name}.partial-{os.getpid()}"
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        if tmp.exists():
            shutil.rmtree(tmp)
        tmp.mkdir()
        _write_all(tmp, content)
        if out.is_dir():
            if not any(out.iterdir()):
                out.rmdir()
            elif overwrite and _is_scene_folder(out):
                shutil.rmtree(out)  # an earlier scene folder, replaced on request
            else:
                raise SceneFolderError(f"output folder {out} is not empty")
        os.replace(tmp, out)
    except OSError as exc:
        shutil.rmtree(tmp, ignore_errors=True)
        reason = exc.strerror or str(exc)
        raise SceneFolderError(f"cannot write scene folder {out}: {reason}") from exc
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return out


def round_floats(values: Any, digits: int = 6) -> Any:
    """Nested lists / tuples / arrays of numbers as lists of floats rounded to ``digits``."""
    arr = np.asarray(values, dtype=np.float64)
    return np.round(arr, digits).tolist()
