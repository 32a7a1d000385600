"""The two types every loader returns: :class:`GaussianScene` and :class:`Camera` (numpy only).

Conventions, written down once for the whole project:

- **Quaternions** are ``wxyz``.
- **Gaussian parameters are stored raw**, as a 3DGS optimiser and the INRIA PLY keep them:
  ``log_scales`` (log of the per-axis standard deviation), ``opacity_logits`` and quaternions
  of any non-zero norm. The activations are properties: :attr:`GaussianScene.scales` (exp),
  :attr:`GaussianScene.opacities` (sigmoid), :attr:`GaussianScene.rotations` (normalised
  quaternions) and :attr:`GaussianScene.colors` (SH DC to RGB). Keeping the raw values makes a
  PLY read/write round trip byte-exact; every consumer uses the activated properties.
- **Cameras** are OpenCV pinhole cameras: x right, y down, z forward (looking along +z),
  intrinsics in pixels, and the pose as ``T_cam_world`` (world to camera, 4x4 float64).
  Pixel ``(row i, column j)`` covers ``[j, j+1) x [i, i+1)`` and is sampled at its centre
  ``(j + 0.5, i + 0.5)`` (the COLMAP convention), so the image centre is ``(W/2, H/2)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike
from scipy.special import expit

from causalsplat.io._geometry import quat_to_rotmat
from causalsplat.io.errors import InvalidSceneError

#: Zeroth-order real spherical-harmonic constant: RGB = 0.5 + SH_C0 * f_dc.
SH_C0 = 0.28209479177387814


def _as_float32(name: str, value: object, shape: tuple[int | None, ...]) -> np.ndarray:
    arr = np.ascontiguousarray(value, dtype=np.float32)
    if arr.ndim != len(shape) or any(s is not None and s != a for s, a in zip(shape, arr.shape)):
        want = "x".join("N" if s is None else str(s) for s in shape)
        raise InvalidSceneError(f"GaussianScene.{name}: expected shape ({want}), got {arr.shape}")
    bad = ~np.isfinite(arr)
    if bad.any():
        first = int(np.argwhere(bad)[0][0])
        raise InvalidSceneError(
            f"GaussianScene.{name}: {int(bad.sum())} non-finite value(s), first at Gaussian {first}"
        )
    return arr


@dataclass(frozen=True, slots=True, eq=False, weakref_slot=True)
class GaussianScene:
    """A 3D Gaussian Splatting scene (raw parameters, see the module docstring).

    Attributes:
        means: (N, 3) float32, Gaussian centres, world frame, scene units.
        quats: (N, 4) float32, rotations as wxyz quaternions of any non-zero norm
            (a zero quaternion raises :class:`InvalidSceneError`).
        log_scales: (N, 3) float32, log of the per-axis standard deviation (scene units).
        opacity_logits: (N,) float32, opacity = sigmoid(logit).
        sh: (N, K, 3) float32 real SH coefficients per colour channel, K = (degree+1)**2 with
            degree 0..3; ``sh[:, 0]`` is the DC term.

    Inputs are converted to contiguous float32; shapes and finiteness are checked.
    """

    means: np.ndarray
    quats: np.ndarray
    log_scales: np.ndarray
    opacity_logits: np.ndarray
    sh: np.ndarray

    def __post_init__(self) -> None:
        means = _as_float32("means", self.means, (None, 3))
        n = means.shape[0]
        quats = _as_float32("quats", self.quats, (n, 4))
        log_scales = _as_float32("log_scales", self.log_scales, (n, 3))
        logits = _as_float32("opacity_logits", self.opacity_logits, (n,))
        sh = _as_float32("sh", self.sh, (n, None, 3))
        if sh.shape[1] not in (1, 4, 9, 16):
            raise InvalidSceneError(
                f"GaussianScene.sh: K={sh.shape[1]} coefficients is not (degree+1)**2 for 0..3"
            )
        zero = np.linalg.norm(quats.astype(np.float64), axis=1) == 0.0
        if zero.any():
            raise InvalidSceneError(
                f"GaussianScene.quats: {int(zero.sum())} zero quaternion(s), first at Gaussian "
                f"{int(np.argmax(zero))}; use (1, 0, 0, 0) for no rotation"
            )
        for name, arr in (
            ("means", means),
            ("quats", quats),
            ("log_scales", log_scales),
            ("opacity_logits", logits),
            ("sh", sh),
        ):
            object.__setattr__(self, name, arr)

    @property
    def n(self) -> int:
        """Number of Gaussians."""
        return int(self.means.shape[0])

    @property
    def sh_degree(self) -> int:
        """SH degree (0..3)."""
        return math.isqrt(self.sh.shape[1]) - 1

    @property
    def opacities(self) -> np.ndarray:
        """(N,) float32 opacity in [0, 1] (sigmoid of the logits, overflow-free)."""
        return expit(self.opacity_logits.astype(np.float64)).astype(np.float32)

    @property
    def scales(self) -> np.ndarray:
        """(N, 3) float64 per-axis standard deviation, scene units (exp of the log scales)."""
        return np.exp(self.log_scales.astype(np.float64))

    @property
    def rotations(self) -> np.ndarray:
        """(N, 4) float64 unit quaternions, wxyz."""
        q = self.quats.astype(np.float64)
        return q / np.linalg.norm(q, axis=1, keepdims=True)

    @property
    def rotation_matrices(self) -> np.ndarray:
        """(N, 3, 3) float64 rotation matrices (local Gaussian axes to world)."""
        return quat_to_rotmat(self.quats)

    @property
    def colors(self) -> np.ndarray:
        """(N, 3) float32 view-independent RGB in [0, 1]: ``clip(0.5 + SH_C0 * dc, 0, 1)``."""
        return np.clip(0.5 + SH_C0 * self.sh[:, 0, :], 0.0, 1.0).astype(np.float32)

    def subset(self, index: np.ndarray) -> GaussianScene:
        """A scene of the Gaussians selected by ``index`` (bool mask or integer indices)."""
        return GaussianScene(
            means=self.means[index],
            quats=self.quats[index],
            log_scales=self.log_scales[index],
            opacity_logits=self.opacity_logits[index],
            sh=self.sh[index],
        )

    @classmethod
    def from_points(
        cls,
        means: np.ndarray,
        colors_rgb01: np.ndarray,
        scales: np.ndarray | float,
        opacity: np.ndarray | float = 0.9,
    ) -> GaussianScene:
        """Axis-aligned Gaussians with DC-only SH from points and colours.

        Args:
            means: (N, 3) centres, world frame, scene units.
            colors_rgb01: (N, 3) RGB in [0, 1].
            scales: standard deviation(s), scene units: a scalar, (N,) isotropic or (N, 3).
            opacity: opacity in (0, 1), a scalar or (N,); clipped to [1e-6, 1 - 1e-6].
        """
        means = np.asarray(means, dtype=np.float64)
        n = means.shape[0] if means.ndim == 2 else -1
        colors = np.asarray(colors_rgb01, dtype=np.float64)
        if colors.shape != (n, 3):
            raise InvalidSceneError(f"colors_rgb01: expected shape ({n}, 3), got {colors.shape}")
        sc = np.asarray(scales, dtype=np.float64)
        if sc.ndim == 1:
            sc = sc[:, None]
        try:
            sc = np.broadcast_to(sc, (n, 3))
        except ValueError as exc:
            raise InvalidSceneError(f"scales: shape {sc.shape} does not fit {n} Gaussians") from exc
        if not np.all(sc > 0):
            raise InvalidSceneError("scales: every standard deviation must be > 0")
        op = np.clip(np.broadcast_to(np.asarray(opacity, dtype=np.float64), (n,)), 1e-6, 1 - 1e-6)
        quats = np.zeros((n, 4), dtype=np.float32)
        quats[:, 0] = 1.0
        return cls(
            means=means,
            quats=quats,
            log_scales=np.log(sc),
            opacity_logits=np.log(op) - np.log1p(-op),
            sh=((colors - 0.5) / SH_C0)[:, None, :],
        )


class Projection(NamedTuple):
    """Pixel coordinates and depth of projected points (see :meth:`Camera.project`)."""

    pixels: np.ndarray  #: (M, 2) float64, (u, v) = (column, row) in pixels; NaN where depth <= 0
    depth: np.ndarray  #: (M,) float64, z in the camera frame (scene units); <= 0 is behind


#: Focal lengths and principal points beyond this many times a camera's longer side (a field
#: of view under 0.006 degree, a centre that far off the image) are refused as corrupt.
MAX_INTRINSICS_PER_SIDE = 1e4


@dataclass(frozen=True, slots=True, eq=False)
class Camera:
    """A pinhole camera, OpenCV convention (x right, y down, z forward; see module docstring).

    Attributes:
        name: image name or path as given by the source (COLMAP NAME, transforms ``file_path``).
        width, height: image size in pixels.
        fx, fy, cx, cy: intrinsics in pixels; pixel centres are at half-integers.
        T_cam_world: (4, 4) float64, rigid world-to-camera transform ``x_cam = T @ x_world``.
    """

    name: str
    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    T_cam_world: np.ndarray

    def __post_init__(self) -> None:
        T = np.array(self.T_cam_world, dtype=np.float64)
        if T.shape != (4, 4) or not np.all(np.isfinite(T)):
            raise InvalidSceneError(f"Camera {self.name!r}: T_cam_world must be finite 4x4")
        if not np.allclose(T[3], [0, 0, 0, 1]) or not np.allclose(
            T[:3, :3] @ T[:3, :3].T, np.eye(3), atol=1e-4
        ):
            raise InvalidSceneError(f"Camera {self.name!r}: T_cam_world is not a rigid transform")
        if int(self.width) <= 0 or int(self.height) <= 0:
            raise InvalidSceneError(f"Camera {self.name!r}: size {self.width}x{self.height}")
        intr = (self.fx, self.fy, self.cx, self.cy)
        if not all(np.isfinite(intr)) or self.fx <= 0 or self.fy <= 0:
            raise InvalidSceneError(f"Camera {self.name!r}: bad intrinsics {intr}")
        side = max(int(self.width), int(self.height))
        bound = MAX_INTRINSICS_PER_SIDE * side
        if max(self.fx, self.fy, abs(self.cx), abs(self.cy)) > bound:
            raise InvalidSceneError(
                f"Camera {self.name!r}: intrinsics {intr} out of range: fx, fy must be in "
                f"(0, {bound:g}] and |cx|, |cy| at most {bound:g} px ({MAX_INTRINSICS_PER_SIDE:g} "
                f"times the image's longer side, {side} px)"
            )
        T.setflags(write=False)
        object.__setattr__(self, "T_cam_world", T)
        object.__setattr__(self, "width", int(self.width))
        object.__setattr__(self, "height", int(self.height))
        for key in ("fx", "fy", "cx", "cy"):
            object.__setattr__(self, key, float(getattr(self, key)))

    @property
    def R_cam_world(self) -> np.ndarray:
        """(3, 3) float64 rotation part of :attr:`T_cam_world`."""
        return self.T_cam_world[:3, :3]

    @property
    def T_world_cam(self) -> np.ndarray:
        """(4, 4) float64 camera-to-world transform."""
        out = np.eye(4)
        out[:3, :3] = self.R_cam_world.T
        out[:3, 3] = self.center
        return out

    @property
    def center(self) -> np.ndarray:
        """(3,) float64 camera centre in world coordinates."""
        return -self.R_cam_world.T @ self.T_cam_world[:3, 3]

    @property
    def K(self) -> np.ndarray:
        """(3, 3) float64 intrinsic matrix."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    def world_to_camera(self, points: np.ndarray) -> np.ndarray:
        """(M, 3) world points to (M, 3) float64 camera-frame points.

        The camera centre is subtracted in float64 first, so large world offsets lose nothing.
        """
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        return (p - self.center) @ self.R_cam_world.T

    def project(self, points: np.ndarray) -> Projection:
        """Project (M, 3) world points to pixels; pixels are NaN for depth <= 0."""
        pc = self.world_to_camera(points)
        z = pc[:, 2]
        pix = np.full((pc.shape[0], 2), np.nan)
        ok = z > 0
        pix[ok, 0] = self.fx * pc[ok, 0] / z[ok] + self.cx
        pix[ok, 1] = self.fy * pc[ok, 1] / z[ok] + self.cy
        return Projection(pixels=pix, depth=z)

    def scaled(self, width: int, height: int) -> Camera:
        """The same camera resampled to ``width x height`` pixels (intrinsics scaled)."""
        sx, sy = width / self.width, height / self.height
        return Camera(
            self.name,
            width,
            height,
            self.fx * sx,
            self.fy * sy,
            self.cx * sx,
            self.cy * sy,
            self.T_cam_world,
        )

    @classmethod
    def look_at(
        cls,
        name: str,
        eye: ArrayLike,
        target: ArrayLike,
        up: ArrayLike,
        width: int,
        height: int,
        fov_y_deg: float,
    ) -> Camera:
        """A camera at ``eye`` looking at ``target`` with ``up`` up in the image.

        Square pixels, principal point at the image centre, vertical field of view
        ``fov_y_deg``. Raises :class:`InvalidSceneError` when ``up`` is parallel to the view.
        """
        eye_w = np.asarray(eye, dtype=np.float64)
        forward = np.asarray(target, dtype=np.float64) - eye_w
        norm = float(np.linalg.norm(forward))
        right = np.cross(forward, np.asarray(up, dtype=np.float64))
        if norm == 0 or np.linalg.norm(right) < 1e-12 * max(norm, 1.0):
            raise InvalidSceneError(
                f"Camera.look_at {name!r}: eye == target or up parallel to view"
            )
        forward /= norm
        right /= np.linalg.norm(right)
        down = np.cross(forward, right)
        T = np.eye(4)
        T[:3, :3] = np.stack([right, down, forward])
        T[:3, 3] = -T[:3, :3] @ eye_w
        if not 0 < fov_y_deg < 180:
            raise InvalidSceneError(f"Camera.look_at {name!r}: fov_y_deg={fov_y_deg}")
        f = 0.5 * height / np.tan(np.deg2rad(fov_y_deg) / 2)
        return cls(name, width, height, f, f, width / 2, height / 2, T)
