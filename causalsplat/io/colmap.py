"""COLMAP sparse models (``cameras``, ``images``, ``points3D``; text or binary) to cameras.

COLMAP stores per image the world-to-camera rotation (quaternion ``QW QX QY QZ``) and
translation, with the camera looking along +z, x right, y down, pixel centres at
half-integers: exactly the :class:`~causalsplat.io.types.Camera` convention, so poses are
taken as they are.

Camera models: ``SIMPLE_PINHOLE`` and ``PINHOLE`` are read exactly. ``SIMPLE_RADIAL``,
``RADIAL``, ``OPENCV`` and ``FULL_OPENCV`` are read exactly when their distortion
coefficients are all zero. With a non-zero coefficient the model is refused
(:class:`~causalsplat.io.errors.ColmapDistortionError`: masks would land where the lens did
not put them; undistort the images first, ``colmap image_undistorter``), unless
``allow_distortion=True``: then the camera is read as a pinhole one, its distortion
dropped, and :attr:`ColmapModel.distorted` names it. Fisheye and other models raise
:class:`ColmapFormatError`.
2D keypoints and point tracks are not kept.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from causalsplat.io._geometry import quat_to_rotmat, rotmat_to_quat
from causalsplat.io.errors import ColmapDistortionError, ColmapFormatError, InvalidSceneError
from causalsplat.io.types import Camera

#: COLMAP camera model id -> (name, number of parameters).
CAMERA_MODELS: dict[int, tuple[str, int]] = {
    0: ("SIMPLE_PINHOLE", 3),
    1: ("PINHOLE", 4),
    2: ("SIMPLE_RADIAL", 4),
    3: ("RADIAL", 5),
    4: ("OPENCV", 8),
    5: ("OPENCV_FISHEYE", 8),
    6: ("FULL_OPENCV", 12),
    7: ("FOV", 5),
    8: ("SIMPLE_RADIAL_FISHEYE", 4),
    9: ("RADIAL_FISHEYE", 5),
    10: ("THIN_PRISM_FISHEYE", 12),
}
MODEL_IDS = {name: mid for mid, (name, _) in CAMERA_MODELS.items()}
_SINGLE_FOCAL = {"SIMPLE_PINHOLE", "SIMPLE_RADIAL", "RADIAL"}
_TWO_FOCAL = {"PINHOLE", "OPENCV", "FULL_OPENCV"}
#: Where a pinhole-family model's distortion coefficients start in its parameters.
_DISTORTION_FROM = {"SIMPLE_PINHOLE": 3, "PINHOLE": 4, "SIMPLE_RADIAL": 3, "RADIAL": 3,
                    "OPENCV": 4, "FULL_OPENCV": 4}  # fmt: skip


@dataclass(frozen=True, slots=True)
class RawCamera:
    """One COLMAP camera (intrinsics record) as stored."""

    camera_id: int
    model: str
    width: int
    height: int
    params: tuple[float, ...]


@dataclass(frozen=True, slots=True)
class RawImage:
    """One registered COLMAP image: ``qvec`` (wxyz) and ``tvec`` map world to camera."""

    image_id: int
    qvec: tuple[float, float, float, float]
    tvec: tuple[float, float, float]
    camera_id: int
    name: str


@dataclass(frozen=True, slots=True, eq=False)
class ColmapPoints:
    """The sparse point cloud.

    Attributes:
        ids: (M,) int64 COLMAP point ids.
        xyz: (M, 3) float64 positions, world frame, model units.
        rgb: (M, 3) uint8 colours.
        error: (M,) float64 mean reprojection error, pixels.
    """

    ids: np.ndarray
    xyz: np.ndarray
    rgb: np.ndarray
    error: np.ndarray

    @classmethod
    def empty(cls) -> ColmapPoints:
        return cls(np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros((0, 3), np.uint8), np.zeros(0))


@dataclass(frozen=True, slots=True, eq=False)
class ColmapModel:
    """A COLMAP sparse model turned into cameras.

    Attributes:
        cameras: one :class:`Camera` per registered image, ordered by image id; the camera
            name is the image NAME.
        image_ids: the COLMAP image id of each camera.
        points: the sparse points (empty when ``points3D`` is absent).
        distorted: ``"camera <id> (<MODEL>, largest coefficient <c>)"`` for each camera
            whose distortion was dropped (only with ``allow_distortion=True``).
    """

    cameras: tuple[Camera, ...]
    image_ids: tuple[int, ...]
    points: ColmapPoints
    distorted: tuple[str, ...] = ()


def distortion(cam: RawCamera) -> float:
    """The largest absolute distortion coefficient of a pinhole-family camera (0: none)."""
    start = _DISTORTION_FROM.get(cam.model, len(cam.params))
    return max((abs(c) for c in cam.params[start:]), default=0.0)


def describe_distortion(cam: RawCamera) -> str:
    return f"camera {cam.camera_id} ({cam.model}, largest coefficient {distortion(cam):.3g})"


def pinhole_intrinsics(cam: RawCamera, source: Path) -> tuple[float, float, float, float]:
    """(fx, fy, cx, cy) of a COLMAP camera; distortion parameters are not read here."""
    p = cam.params
    if cam.model in _SINGLE_FOCAL:
        return p[0], p[0], p[1], p[2]
    if cam.model in _TWO_FOCAL:
        return p[0], p[1], p[2], p[3]
    raise ColmapFormatError(
        f"{source}: camera {cam.camera_id} has model {cam.model}, which is not a pinhole "
        "model; undistort the images first (colmap image_undistorter)"
    )


def check_distortion(
    cameras: dict[int, RawCamera], source: Path, *, allow_distortion: bool = False
) -> tuple[str, ...]:
    """The cameras with non-zero distortion (described); raises
    :class:`ColmapDistortionError` for the first of them unless ``allow_distortion``."""
    distorted = [cam for _, cam in sorted(cameras.items()) if distortion(cam) != 0.0]
    if distorted and not allow_distortion:
        more = f" (and {len(distorted) - 1} more)" if len(distorted) > 1 else ""
        raise ColmapDistortionError(
            f"{source}: {describe_distortion(distorted[0])}{more} has lens distortion, which "
            "would put the masks where the lens did not; undistort the images first (colmap "
            "image_undistorter) or pass --allow-distortion to read it as a pinhole camera"
        )
    return tuple(describe_distortion(cam) for cam in distorted)


def to_cameras(
    cameras: dict[int, RawCamera], images: list[RawImage], source: Path
) -> tuple[tuple[Camera, ...], tuple[int, ...]]:
    """Build :class:`Camera` objects from raw records, ordered by image id (distortion
    coefficients are not read: see :func:`check_distortion`)."""
    out, ids = [], []
    for img in sorted(images, key=lambda im: im.image_id):
        cam = cameras.get(img.camera_id)
        if cam is None:
            raise ColmapFormatError(
                f"{source}: image {img.image_id} ({img.name}) refers to missing camera "
                f"{img.camera_id}"
            )
        if np.linalg.norm(img.qvec) == 0 or not np.all(np.isfinite(img.qvec + img.tvec)):
            raise ColmapFormatError(f"{source}: image {img.image_id} has an invalid pose")
        T = np.eye(4)
        T[:3, :3] = quat_to_rotmat(np.asarray(img.qvec))
        T[:3, 3] = img.tvec
        fx, fy, cx, cy = pinhole_intrinsics(cam, source)
        try:
            out.append(Camera(img.name, cam.width, cam.height, fx, fy, cx, cy, T))
        except InvalidSceneError as exc:
            raise ColmapFormatError(f"{source}: image {img.image_id}: {exc}") from exc
        ids.append(img.image_id)
    return tuple(out), tuple(ids)


def _find(path: Path, stem: str) -> tuple[Path, bool] | None:
    for ext, binary in ((".bin", True), (".txt", False)):
        candidate = path / f"{stem}{ext}"
        if candidate.exists():
            return candidate, binary
    return None


def read_colmap_model(
    path: str | os.PathLike[str], *, allow_distortion: bool = False
) -> ColmapModel:
    """Read a COLMAP sparse model folder (e.g. ``sparse/0``), binary or text.

    Binary files (``*.bin``) are preferred when both forms are present. ``cameras`` and
    ``images`` are required, ``points3D`` is optional. Raises :class:`ColmapFormatError`
    naming the file for missing, truncated or malformed files and unsupported models, and
    :class:`ColmapDistortionError` for a camera with lens distortion unless
    ``allow_distortion`` (module docstring).
    """
    from causalsplat.io import _colmap_binary, _colmap_text

    path = Path(path)
    found = {stem: _find(path, stem) for stem in ("cameras", "images", "points3D")}
    for stem in ("cameras", "images"):
        if found[stem] is None:
            raise ColmapFormatError(f"{path}: no {stem}.bin or {stem}.txt")
    cam_file, cam_bin = found["cameras"]  # type: ignore[misc]
    img_file, img_bin = found["images"]  # type: ignore[misc]
    cameras = (_colmap_binary if cam_bin else _colmap_text).read_cameras(cam_file)
    distorted = check_distortion(cameras, cam_file, allow_distortion=allow_distortion)
    images = (_colmap_binary if img_bin else _colmap_text).read_images(img_file)
    points = ColmapPoints.empty()
    if found["points3D"] is not None:
        pt_file, pt_bin = found["points3D"]
        points = (_colmap_binary if pt_bin else _colmap_text).read_points(pt_file)
    cams, ids = to_cameras(cameras, images, img_file)
    return ColmapModel(cameras=cams, image_ids=ids, points=points, distorted=distorted)


def write_colmap_model(
    path: str | os.PathLike[str], model: ColmapModel, *, binary: bool = False
) -> None:
    """Write ``model`` as a COLMAP sparse model (one PINHOLE camera per image, empty tracks).

    Camera ids are 1..n in image order; 2D keypoints and tracks are written empty.
    """
    from causalsplat.io import _colmap_binary, _colmap_text

    path = Path(path)
    path.mkdir(parents=True, exist_ok=True)
    cams: list[RawCamera] = []
    imgs: list[RawImage] = []
    for k, (cam, image_id) in enumerate(zip(model.cameras, model.image_ids), start=1):
        cams.append(
            RawCamera(k, "PINHOLE", cam.width, cam.height, (cam.fx, cam.fy, cam.cx, cam.cy))
        )
        q = rotmat_to_quat(cam.R_cam_world)
        t = cam.T_cam_world[:3, 3]
        qvec = (float(q[0]), float(q[1]), float(q[2]), float(q[3]))
        tvec = (float(t[0]), float(t[1]), float(t[2]))
        imgs.append(RawImage(image_id, qvec, tvec, k, cam.name))
    writer = _colmap_binary if binary else _colmap_text
    writer.write_model(path, cams, imgs, model.points)
