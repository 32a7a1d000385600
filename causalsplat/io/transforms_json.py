"""nerfstudio / instant-ngp ``transforms.json`` cameras.

The file stores per frame a camera-to-world ``transform_matrix`` in the **OpenGL**
convention (x right, y up, camera looking along -z). It is converted once, here, to the
project's OpenCV world-to-camera :class:`~causalsplat.io.types.Camera`:
``T_world_cam_cv = transform_matrix @ diag(1, -1, -1, 1)`` and ``T_cam_world = inv(...)``.

Intrinsics come from per-frame keys when present, else from the top level: ``fl_x``,
``fl_y`` (or ``camera_angle_x`` / ``camera_angle_y``, the instant-ngp field of view in
radians), ``cx``, ``cy`` (default: image centre), ``w``, ``h``. Distortion keys
(``k1``, ``k2``, ``p1``, ``p2``...) are ignored. When the file carries nerfstudio's
``applied_transform`` (3x4, the map from the original COLMAP world into the file's world),
``undo_applied_transform=True`` returns the cameras in the original world instead.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from causalsplat._json import JSONInputError, decode_json
from causalsplat.io.errors import InvalidSceneError, TransformsFormatError
from causalsplat.io.types import Camera

#: OpenGL camera axes (x right, y up, z back) to OpenCV (x right, y down, z forward).
GL_TO_CV = np.diag([1.0, -1.0, -1.0, 1.0])


def _number(path: Path, where: str, obj: dict[str, Any], key: str) -> float | None:
    if key not in obj:
        return None
    try:
        value = float(obj[key])
    except (TypeError, ValueError) as exc:
        raise TransformsFormatError(f"{path}: {where}{key}={obj[key]!r} is not a number") from exc
    if not math.isfinite(value):
        raise TransformsFormatError(f"{path}: {where}{key} is not finite")
    return value


def _intrinsics(
    path: Path, top: dict[str, Any], frame: dict[str, Any], k: int
) -> tuple[float, ...]:
    def get(key: str) -> float | None:
        v = _number(path, f"frames[{k}].", frame, key)
        return v if v is not None else _number(path, "", top, key)

    w, h = get("w"), get("h")
    if w is None or h is None:
        raise TransformsFormatError(f"{path}: frames[{k}]: image size 'w'/'h' is missing")
    fx, fy = get("fl_x"), get("fl_y")
    ax, ay = get("camera_angle_x"), get("camera_angle_y")
    for key, value in (("w", w), ("h", h), ("fl_x", fx), ("fl_y", fy)):
        if value is not None and value <= 0:
            raise TransformsFormatError(f"{path}: frames[{k}]: {key} must be > 0, got {value}")
    for key, value in (("camera_angle_x", ax), ("camera_angle_y", ay)):
        if value is not None and not 0 < value < math.pi:
            raise TransformsFormatError(
                f"{path}: frames[{k}]: {key} must be in (0, pi) radians, got {value}"
            )
    if fx is None and ax is not None:
        fx = 0.5 * w / math.tan(0.5 * ax)
    if fy is None and ay is not None:
        fy = 0.5 * h / math.tan(0.5 * ay)
    fx, fy = fx if fx is not None else fy, fy if fy is not None else fx
    if fx is None or fy is None:
        raise TransformsFormatError(
            f"{path}: frames[{k}]: no focal length (fl_x/fl_y or camera_angle_x/y)"
        )
    cx, cy = get("cx"), get("cy")
    return w, h, fx, fy, (w / 2 if cx is None else cx), (h / 2 if cy is None else cy)


def _matrix(path: Path, value: Any, where: str, rows: int) -> np.ndarray:
    try:
        m = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise TransformsFormatError(f"{path}: {where} is not a numeric matrix") from exc
    if m.shape not in ((rows, 4), (4, 4)) or not np.all(np.isfinite(m)):
        raise TransformsFormatError(f"{path}: {where} must be a finite {rows}x4 matrix")
    out = np.eye(4)
    out[:3] = m[:3]
    return out


def read_transforms_json(
    path: str | os.PathLike[str], *, undo_applied_transform: bool = False
) -> tuple[Camera, ...]:
    """Cameras of a ``transforms.json`` (OpenCV, world-to-camera), in file order.

    The camera name is the frame's ``file_path``. Raises :class:`TransformsFormatError`
    naming the file and key for malformed input.
    """
    path = Path(path)
    try:
        top = decode_json(path.read_bytes())
    except (OSError, JSONInputError) as exc:
        raise TransformsFormatError(f"{path}: cannot read JSON: {exc}") from exc
    frames = top.get("frames") if isinstance(top, dict) else None
    if not isinstance(frames, list):
        raise TransformsFormatError(f"{path}: no 'frames' list")
    undo = np.eye(4)
    if undo_applied_transform and "applied_transform" in top:
        undo = np.linalg.inv(_matrix(path, top["applied_transform"], "applied_transform", 3))
    cams = []
    for k, frame in enumerate(frames):
        if not isinstance(frame, dict) or "transform_matrix" not in frame:
            raise TransformsFormatError(f"{path}: frames[{k}] has no transform_matrix")
        c2w = undo @ _matrix(path, frame["transform_matrix"], f"frames[{k}].transform_matrix", 4)
        T_world_cam = c2w @ GL_TO_CV
        rot = T_world_cam[:3, :3]
        T = np.eye(4)
        T[:3, :3] = rot.T
        T[:3, 3] = -rot.T @ T_world_cam[:3, 3]
        w, h, fx, fy, cx, cy = _intrinsics(path, top, frame, k)
        name = str(frame.get("file_path", f"frame_{k:05d}"))
        try:
            cams.append(Camera(name, round(w), round(h), fx, fy, cx, cy, T))
        except InvalidSceneError as exc:
            raise TransformsFormatError(f"{path}: frames[{k}]: {exc}") from exc
    return tuple(cams)


def write_transforms_json(path: str | os.PathLike[str], cameras: tuple[Camera, ...]) -> None:
    """Write cameras as a nerfstudio ``transforms.json`` (per-frame intrinsics, OpenGL c2w)."""
    frames = []
    for cam in cameras:
        c2w = cam.T_world_cam @ GL_TO_CV  # GL_TO_CV is its own inverse
        frames.append(
            {
                "file_path": cam.name,
                "w": cam.width,
                "h": cam.height,
                "fl_x": cam.fx,
                "fl_y": cam.fy,
                "cx": cam.cx,
                "cy": cam.cy,
                "transform_matrix": c2w.tolist(),
            }
        )
    Path(path).write_text(json.dumps({"frames": frames}, indent=2), encoding="utf-8")
