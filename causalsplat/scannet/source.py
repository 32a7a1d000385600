"""Reading the ScanNet scene0000_00 files of ``../shared/data/scannet_scene0000_00``.

Paths inside the source folder (see its ``SOURCE.md``):

- ``mmdet3d_votenet_format/<scan>_vert_all.npy``: (N, 6) float32 x, y, z (metres, axis-aligned
  frame, z up), r, g, b (0-255), every vertex of the ScanNet mesh;
- ``mmdet3d_votenet_format/<scan>_ins_label_all.npy``: (N,) instance label per vertex,
  0 = unannotated, k > 0 = ScanNet v2 objectId k - 1;
- ``language_gt/objects_info_<scan>.json``: the object table (id = v2 objectId, label, AABB);
- ``mmdet3d_posed_images/cameras_<scan>.json`` and the JPEGs it names: colour intrinsics,
  ``axis_align_matrix`` and per frame the raw ScanNet camera-to-world pose (OpenCV);
- ``language_gt/{sr3d,nr3d}_<scan>.csv``, ``language_gt/scanrefer_<scan>.json``: utterances
  with target object ids.
"""

from __future__ import annotations

import csv
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from causalsplat.errors import InputFormatError


class ScanNetFormatError(InputFormatError):
    """A ScanNet source file is missing a field, has a wrong shape, or disagrees with another."""


@dataclass(frozen=True, slots=True)
class ScanNetObject:
    """One row of the object table (axis-aligned frame, metres).

    Attributes:
        id: ScanNet v2 objectId (= instance label - 1).
        label: raw ScanNet category name (``sink``, ``kitchen cabinets``...).
        center: AABB centre (x, y, z); size: AABB extent.
    """

    id: int
    label: str
    center: tuple[float, float, float]
    size: tuple[float, float, float]


@dataclass(frozen=True, slots=True)
class RealFrame:
    """A real posed photo: its image file and its camera-to-world pose in the aligned frame.

    Attributes:
        image: path of the JPEG.
        T_world_cam: (4, 4) float64, ``axis_align_matrix @ camera_to_world_unaligned`` (OpenCV).
    """

    image: Path
    T_world_cam: np.ndarray


@dataclass(frozen=True, slots=True, eq=False)
class ScanNetSource:
    """The parsed source files of one scan.

    Attributes:
        scan_id: e.g. ``scene0000_00``.
        xyz: (N, 3) float64 vertex positions, metres, axis-aligned frame, z up.
        rgb: (N, 3) float64 vertex colours in [0, 1].
        instance: (N,) int64 GT instance per vertex: v2 objectId, -1 unannotated.
        objects: the object table, ordered by id.
        intrinsics: (fx, fy, cx, cy) of the colour camera at ``image_size``.
        image_size: (width, height) of the real photos.
        frames: the real posed photos.
        root: the source folder.
    """

    scan_id: str
    xyz: np.ndarray
    rgb: np.ndarray
    instance: np.ndarray
    objects: tuple[ScanNetObject, ...]
    intrinsics: tuple[float, float, float, float]
    image_size: tuple[int, int]
    frames: tuple[RealFrame, ...]
    root: Path


def _require(path: Path) -> Path:
    if not path.is_file():
        raise FileNotFoundError(2, "ScanNet source file not found", str(path))
    return path


def _read_json(path: Path) -> Any:
    try:
        return json.loads(_require(path).read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        raise ScanNetFormatError(f"{path}: not valid JSON ({exc})") from exc


def _objects(path: Path) -> tuple[ScanNetObject, ...]:
    table = _read_json(path)
    rows = table.get("objects") if isinstance(table, dict) else None
    if not isinstance(rows, list):
        raise ScanNetFormatError(f"{path}: no 'objects' list")
    out = []
    for k, row in enumerate(rows):
        try:
            center = tuple(float(v) for v in row["center_position"])
            size = tuple(float(v) for v in row["size"])
            out.append(ScanNetObject(int(row["id"]), str(row["label"]), center, size))  # type: ignore[arg-type]
        except (KeyError, TypeError, ValueError) as exc:
            raise ScanNetFormatError(f"{path}: objects[{k}] is malformed ({exc!r})") from exc
    return tuple(sorted(out, key=lambda o: o.id))


def _vertices(root: Path, scan: str) -> tuple[np.ndarray, np.ndarray]:
    base = root / "mmdet3d_votenet_format"
    vert = np.load(_require(base / f"{scan}_vert_all.npy"), allow_pickle=False)
    labels = np.load(_require(base / f"{scan}_ins_label_all.npy"), allow_pickle=False)
    if vert.ndim != 2 or vert.shape[1] < 6:
        raise ScanNetFormatError(f"{base}/{scan}_vert_all.npy: shape {vert.shape}; want (N, 6)")
    if labels.shape != (vert.shape[0],):
        raise ScanNetFormatError(
            f"{base}/{scan}_ins_label_all.npy: shape {labels.shape}; want ({vert.shape[0]},)"
        )
    if not np.all(np.isfinite(vert[:, :6])):
        raise ScanNetFormatError(f"{base}/{scan}_vert_all.npy: NaN or Inf values")
    return vert, labels.astype(np.int64)


def _cameras(
    root: Path, scan: str
) -> tuple[tuple[float, ...], tuple[int, int], tuple[RealFrame, ...]]:
    folder = root / "mmdet3d_posed_images"
    path = folder / f"cameras_{scan}.json"
    doc = _read_json(path)
    try:
        k = np.asarray(doc["intrinsics_color_4x4"], dtype=np.float64)
        align = np.asarray(doc["axis_align_matrix"], dtype=np.float64)
        width, height = (int(v) for v in doc["image_size_wh"])
        frames = tuple(
            RealFrame(
                image=_require(folder / str(f["image"])),
                T_world_cam=align @ np.asarray(f["camera_to_world_unaligned"], dtype=np.float64),
            )
            for f in doc["frames"]
        )
    except (KeyError, TypeError, ValueError) as exc:
        raise ScanNetFormatError(f"{path}: malformed camera record ({exc!r})") from exc
    if k.shape != (4, 4) or align.shape != (4, 4):
        raise ScanNetFormatError(f"{path}: intrinsics and axis_align_matrix must be 4x4")
    return (k[0, 0], k[1, 1], k[0, 2], k[1, 2]), (width, height), frames


def load_scannet(src_dir: str | Path, scan_id: str = "scene0000_00") -> ScanNetSource:
    """Read and cross-check the source files of ``scan_id`` under ``src_dir``."""
    root = Path(src_dir)
    if not root.is_dir():
        raise FileNotFoundError(2, "No such ScanNet source folder", str(root))
    vert, labels = _vertices(root, scan_id)
    objects = _objects(root / "language_gt" / f"objects_info_{scan_id}.json")
    ids = [o.id for o in objects]
    if ids != list(range(len(ids))):
        raise ScanNetFormatError(f"objects_info_{scan_id}.json: ids are not 0..{len(ids) - 1}")
    if labels.min() < 0 or labels.max() > len(objects):
        raise ScanNetFormatError(
            f"{scan_id}_ins_label_all.npy: labels span {labels.min()}..{labels.max()}, "
            f"but the object table has {len(objects)} objects"
        )
    intrinsics, size, frames = _cameras(root, scan_id)
    return ScanNetSource(
        scan_id=scan_id,
        xyz=vert[:, :3].astype(np.float64),
        rgb=np.clip(vert[:, 3:6].astype(np.float64) / 255.0, 0.0, 1.0),
        instance=labels - 1,
        objects=objects,
        intrinsics=intrinsics,  # type: ignore[arg-type]
        image_size=size,
        frames=frames,
        root=root,
    )


def read_csv_rows(path: Path) -> list[dict[str, str]]:
    """Rows of a CSV file with a header line."""
    with open(_require(path), newline="", encoding="utf-8") as fh:
        return list(csv.DictReader(fh))
