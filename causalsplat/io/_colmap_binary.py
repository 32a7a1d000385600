"""COLMAP binary format (``cameras.bin``, ``images.bin``, ``points3D.bin``), little-endian."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np

from causalsplat.io.colmap import CAMERA_MODELS, MODEL_IDS, ColmapPoints, RawCamera, RawImage
from causalsplat.io.errors import ColmapFormatError


class _Reader:
    """Bounds-checked sequential reader; every overrun is a typed error naming the file."""

    def __init__(self, path: Path) -> None:
        self.path = path
        try:
            self.buf = path.read_bytes()
        except OSError as exc:
            raise ColmapFormatError(f"{path}: cannot read: {exc}") from exc
        self.pos = 0

    def unpack(self, fmt: str, what: str) -> tuple:  # type: ignore[type-arg]
        size = struct.calcsize("<" + fmt)
        if self.pos + size > len(self.buf):
            raise ColmapFormatError(
                f"{self.path}: truncated at byte {self.pos} while reading {what}"
            )
        vals = struct.unpack_from("<" + fmt, self.buf, self.pos)
        self.pos += size
        return vals

    def skip(self, size: int, what: str) -> None:
        if size < 0 or self.pos + size > len(self.buf):
            raise ColmapFormatError(f"{self.path}: truncated at byte {self.pos} in {what}")
        self.pos += size

    def cstring(self, what: str) -> str:
        end = self.buf.find(b"\x00", self.pos)
        if end < 0:
            raise ColmapFormatError(f"{self.path}: unterminated string in {what}")
        raw = self.buf[self.pos : end]
        self.pos = end + 1
        try:
            return raw.decode("utf-8")
        except UnicodeDecodeError as exc:
            raise ColmapFormatError(f"{self.path}: {what} is not UTF-8") from exc

    def finish(self) -> None:
        if self.pos != len(self.buf):
            raise ColmapFormatError(
                f"{self.path}: {len(self.buf) - self.pos} unexpected trailing bytes"
            )


def _count(r: _Reader, what: str) -> int:
    (n,) = r.unpack("Q", f"number of {what}")
    if n > len(r.buf):  # every record takes at least one byte: a corrupt count
        raise ColmapFormatError(f"{r.path}: implausible number of {what}: {n}")
    return int(n)


def read_cameras(path: Path) -> dict[int, RawCamera]:
    r = _Reader(path)
    out: dict[int, RawCamera] = {}
    for k in range(_count(r, "cameras")):
        cam_id, model_id, width, height = r.unpack("iiQQ", f"camera {k}")
        if model_id not in CAMERA_MODELS:
            raise ColmapFormatError(f"{path}: camera {cam_id} has unknown model id {model_id}")
        name, n_params = CAMERA_MODELS[model_id]
        params = r.unpack("d" * n_params, f"parameters of camera {cam_id}")
        out[cam_id] = RawCamera(cam_id, name, int(width), int(height), tuple(params))
    r.finish()
    return out


def read_images(path: Path) -> list[RawImage]:
    r = _Reader(path)
    out: list[RawImage] = []
    for k in range(_count(r, "images")):
        vals = r.unpack("I7di", f"image {k}")
        name = r.cstring(f"name of image {vals[0]}")
        (n2d,) = r.unpack("Q", f"2D point count of image {vals[0]}")
        r.skip(24 * int(n2d), f"2D points of image {vals[0]}")
        out.append(RawImage(int(vals[0]), vals[1:5], vals[5:8], int(vals[8]), name))
    r.finish()
    return out


def read_points(path: Path) -> ColmapPoints:
    r = _Reader(path)
    n = _count(r, "points")
    ids = np.empty(n, np.int64)
    xyz = np.empty((n, 3))
    rgb = np.empty((n, 3), np.uint8)
    err = np.empty(n)
    for k in range(n):
        vals = r.unpack("Q3d3BdQ", f"point {k}")
        ids[k], xyz[k], rgb[k], err[k] = vals[0], vals[1:4], vals[4:7], vals[7]
        r.skip(8 * int(vals[8]), f"track of point {vals[0]}")
    r.finish()
    return ColmapPoints(ids, xyz, rgb, err)


def write_model(
    path: Path, cameras: list[RawCamera], images: list[RawImage], points: ColmapPoints
) -> None:
    cam = bytearray(struct.pack("<Q", len(cameras)))
    for c in cameras:
        cam += struct.pack("<iiQQ", c.camera_id, MODEL_IDS[c.model], c.width, c.height)
        cam += struct.pack(f"<{len(c.params)}d", *c.params)
    img = bytearray(struct.pack("<Q", len(images)))
    for im in images:
        img += struct.pack("<I7di", im.image_id, *im.qvec, *im.tvec, im.camera_id)
        img += im.name.encode("utf-8") + b"\x00" + struct.pack("<Q", 0)
    pts = bytearray(struct.pack("<Q", points.ids.shape[0]))
    for k in range(points.ids.shape[0]):
        pts += struct.pack(
            "<Q3d3BdQ",
            int(points.ids[k]),
            *points.xyz[k].tolist(),
            *(int(v) for v in points.rgb[k]),
            float(points.error[k]),
            0,
        )
    (path / "cameras.bin").write_bytes(bytes(cam))
    (path / "images.bin").write_bytes(bytes(img))
    (path / "points3D.bin").write_bytes(bytes(pts))
