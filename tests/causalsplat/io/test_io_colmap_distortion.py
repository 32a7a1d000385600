"""COLMAP cameras with lens distortion: refused with the way out, read as pinhole cameras
only when allowed (then the build says so), and exact when every coefficient is zero."""

from __future__ import annotations

from pathlib import Path

import pytest

from causalsplat.io import ColmapDistortionError, _colmap_binary, _colmap_text, read_colmap_model
from causalsplat.io.colmap import ColmapPoints, RawCamera, RawImage

#: model -> parameters: focal(s), principal point, then the distortion coefficients
PARAMS = {
    "SIMPLE_RADIAL": (70.0, 50.0, 40.0, 0.05),
    "RADIAL": (70.0, 50.0, 40.0, 0.05, -0.01),
    "OPENCV": (70.0, 72.0, 50.0, 40.0, 0.05, -0.01, 0.001, 0.002),
    "FULL_OPENCV": (70.0, 72.0, 50.0, 40.0, 0.05, -0.01, 0.001, 0.002, 0.0, 0.0, 0.0, 0.0),
}
N_PINHOLE = {"SIMPLE_RADIAL": 3, "RADIAL": 3, "OPENCV": 4, "FULL_OPENCV": 4}


def _write(path: Path, model: str, params: tuple[float, ...], binary: bool) -> None:
    path.mkdir(parents=True, exist_ok=True)
    cams = [RawCamera(1, model, 100, 80, params)]
    imgs = [RawImage(1, (1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 1, "a.png")]
    (_colmap_binary if binary else _colmap_text).write_model(path, cams, imgs, ColmapPoints.empty())


@pytest.mark.parametrize("binary", [False, True], ids=["text", "binary"])
@pytest.mark.parametrize("model", sorted(PARAMS))
def test_distortion_is_refused_unless_allowed(tmp_path: Path, model: str, binary: bool) -> None:
    _write(tmp_path, model, PARAMS[model], binary)
    with pytest.raises(ColmapDistortionError) as info:
        read_colmap_model(tmp_path)
    message = str(info.value)
    assert "\n" not in message and f"camera 1 ({model}, largest coefficient 0.05)" in message
    assert "colmap image_undistorter" in message and "--allow-distortion" in message
    allowed = read_colmap_model(tmp_path, allow_distortion=True)
    assert allowed.distorted == (f"camera 1 ({model}, largest coefficient 0.05)",)
    cam = allowed.cameras[0]
    fy = PARAMS[model][1] if N_PINHOLE[model] == 4 else PARAMS[model][0]
    assert (cam.fx, cam.fy, cam.cx, cam.cy) == (70.0, fy, 50.0, 40.0)


@pytest.mark.parametrize("model", sorted(PARAMS))
def test_zero_coefficients_read_as_the_pinhole_camera_they_are(tmp_path: Path, model: str) -> None:
    k = N_PINHOLE[model]
    params = PARAMS[model][:k] + (0.0,) * (len(PARAMS[model]) - k)
    _write(tmp_path, model, params, binary=False)
    read = read_colmap_model(tmp_path)
    assert read.distorted == () and read.cameras[0].fx == 70.0


def distort(folder: Path) -> None:
    """The scene folder's COLMAP cameras rewritten as OPENCV with a small k1."""
    sparse = folder / "sparse" / "0"
    model = read_colmap_model(sparse)
    binary = (sparse / "cameras.bin").exists()
    for f in sparse.iterdir():
        f.unlink()
    cams, imgs = [], []
    for k, (cam, image_id) in enumerate(zip(model.cameras, model.image_ids, strict=True), 1):
        params = (cam.fx, cam.fy, cam.cx, cam.cy, 0.02, 0.0, 0.0, 0.0)
        cams.append(RawCamera(k, "OPENCV", cam.width, cam.height, params))
        q = _quat(cam)
        t = cam.T_cam_world[:3, 3]
        imgs.append(RawImage(image_id, q, (float(t[0]), float(t[1]), float(t[2])), k, cam.name))
    (_colmap_binary if binary else _colmap_text).write_model(sparse, cams, imgs, model.points)


def _quat(cam: object) -> tuple[float, float, float, float]:
    from causalsplat.io._geometry import rotmat_to_quat

    q = rotmat_to_quat(cam.R_cam_world)  # type: ignore[attr-defined]
    return (float(q[0]), float(q[1]), float(q[2]), float(q[3]))
