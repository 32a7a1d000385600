"""COLMAP text format (``cameras.txt``, ``images.txt``, ``points3D.txt``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from causalsplat.io.colmap import CAMERA_MODELS, MODEL_IDS, ColmapPoints, RawCamera, RawImage
from causalsplat.io.errors import ColmapFormatError


def _lines(path: Path) -> list[tuple[int, str]]:
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ColmapFormatError(f"{path}: cannot read: {exc}") from exc
    return [(i + 1, ln) for i, ln in enumerate(text.splitlines()) if not ln.startswith("#")]


def read_cameras(path: Path) -> dict[int, RawCamera]:
    out: dict[int, RawCamera] = {}
    for lineno, line in _lines(path):
        if not line.strip():
            continue
        f = line.split()
        try:
            model = f[1]
            n_params = CAMERA_MODELS[MODEL_IDS[model]][1] if model in MODEL_IDS else len(f) - 4
            if len(f) != 4 + n_params:
                raise ValueError(f"{model} needs {n_params} parameters, got {len(f) - 4}")
            cam = RawCamera(int(f[0]), model, int(f[2]), int(f[3]), tuple(map(float, f[4:])))
        except (IndexError, ValueError) as exc:
            raise ColmapFormatError(f"{path}:{lineno}: bad camera line: {exc}") from exc
        out[cam.camera_id] = cam
    return out


def read_images(path: Path) -> list[RawImage]:
    lines = _lines(path)
    out: list[RawImage] = []
    i = 0
    while i < len(lines):
        lineno, line = lines[i]
        if not line.strip():
            i += 1
            continue
        f = line.split()
        try:
            if len(f) < 10:
                raise ValueError(f"expected 10 fields, got {len(f)}")
            q = (float(f[1]), float(f[2]), float(f[3]), float(f[4]))
            t = (float(f[5]), float(f[6]), float(f[7]))
            out.append(RawImage(int(f[0]), q, t, int(f[8]), " ".join(f[9:])))
        except ValueError as exc:
            raise ColmapFormatError(f"{path}:{lineno}: bad image line: {exc}") from exc
        i += 1
        if i < len(lines) and _is_points_line(lines[i][1]):
            i += 1  # the image's 2D points (possibly an empty line)
    return out


def _is_points_line(line: str) -> bool:
    """Whether ``line`` is an image's POINTS2D line: empty, or (X, Y, POINT3D_ID) triples.

    COLMAP writes one after every image line; some writers leave out the empty ones, and
    then the next line is the next image's (its name is no number).
    """
    f = line.split()
    if len(f) % 3:
        return False
    try:
        [float(x) for x in f]
    except ValueError:
        return False
    return True


def read_points(path: Path) -> ColmapPoints:
    ids, xyz, rgb, err = [], [], [], []
    for lineno, line in _lines(path):
        if not line.strip():
            continue
        f = line.split()
        try:
            ids.append(int(f[0]))
            xyz.append([float(v) for v in f[1:4]])
            rgb.append([int(v) for v in f[4:7]])
            err.append(float(f[7]))
        except (IndexError, ValueError) as exc:
            raise ColmapFormatError(f"{path}:{lineno}: bad point line: {exc}") from exc
    if not ids:
        return ColmapPoints.empty()
    return ColmapPoints(
        np.asarray(ids, dtype=np.int64),
        np.asarray(xyz, dtype=np.float64),
        np.asarray(rgb, dtype=np.uint8),
        np.asarray(err, dtype=np.float64),
    )


def write_model(
    path: Path, cameras: list[RawCamera], images: list[RawImage], points: ColmapPoints
) -> None:
    cam_lines = [
        "# Camera list with one line of data per camera:",
        "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]",
    ]
    cam_lines += [
        f"{c.camera_id} {c.model} {c.width} {c.height} " + " ".join(repr(p) for p in c.params)
        for c in cameras
    ]
    img_lines = [
        "# Image list with two lines of data per image:",
        "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME",
        "#   POINTS2D[] as (X, Y, POINT3D_ID)",
    ]
    for im in images:
        vals = " ".join(repr(v) for v in (*im.qvec, *im.tvec))
        img_lines += [f"{im.image_id} {vals} {im.camera_id} {im.name}", ""]
    pt_lines = [
        "# 3D point list with one line of data per point:",
        "#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)",
    ]
    for k in range(points.ids.shape[0]):
        x, y, z = (repr(float(v)) for v in points.xyz[k])
        r, g, b = (int(v) for v in points.rgb[k])
        pt_lines.append(f"{int(points.ids[k])} {x} {y} {z} {r} {g} {b} {float(points.error[k])!r}")
    (path / "cameras.txt").write_text("\n".join(cam_lines) + "\n", encoding="utf-8")
    (path / "images.txt").write_text("\n".join(img_lines) + "\n", encoding="utf-8")
    (path / "points3D.txt").write_text("\n".join(pt_lines) + "\n", encoding="utf-8")
