"""Optional GPU backend through gsplat (``pip install gsplat``, CUDA required). Never needed.

Renders the same model as the CPU path (EWA splatting, 3DGS rules, pinhole camera, pixel
centres at half-integers, black background) with ``gsplat.rasterization`` in its
"classic" mode. gsplat bounds each Gaussian at 3 standard deviations, where the CPU path
keeps every pixel with alpha >= ``alpha_min``, so renders agree closely but not to the
last bit. The world is shifted by the camera centre (in float64) before the float32 GPU
arrays are made, so scenes far from the origin keep their precision.
"""

from __future__ import annotations

import importlib.util
from typing import Any

import numpy as np

from causalsplat.errors import MissingDependencyError
from causalsplat.io.types import Camera, GaussianScene
from causalsplat.render.config import RasterConfig

_DEFAULT = RasterConfig()


def is_available() -> bool:
    """True when gsplat is installed and torch sees a CUDA device."""
    if importlib.util.find_spec("gsplat") is None or importlib.util.find_spec("torch") is None:
        return False
    import torch

    return bool(torch.cuda.is_available())


def _require() -> tuple[Any, Any]:
    if not is_available():
        raise MissingDependencyError(
            "the gsplat backend needs a CUDA device and gsplat: pip install gsplat "
            "(the CPU rasterizer in causalsplat.render needs neither)"
        )
    import gsplat
    import torch

    return torch, gsplat


def render_gsplat(
    scene: GaussianScene,
    camera: Camera,
    values: np.ndarray | None = None,
    *,
    config: RasterConfig = _DEFAULT,
) -> np.ndarray:
    """(H, W, C) float32 composite on the GPU: SH colours (C = 3) or per-Gaussian ``values``.

    With ``values`` (N, C) those are composited as they are; without, the scene's SH is
    evaluated per view (0.5 offset, clamped at 0) and the result clipped to [0, 1].
    """
    torch, gsplat = _require()
    dev = torch.device("cuda")
    local = scene.means.astype(np.float64) - camera.center
    view = np.eye(4)
    view[:3, :3] = camera.R_cam_world

    def t(a: np.ndarray) -> Any:
        return torch.as_tensor(np.ascontiguousarray(a), dtype=torch.float32, device=dev)

    colors = t(scene.sh) if values is None else t(values)
    out, _alpha, _meta = gsplat.rasterization(
        means=t(local),
        quats=t(scene.rotations),
        scales=t(scene.scales),
        opacities=t(scene.opacities),
        colors=colors,
        viewmats=t(view)[None],
        Ks=t(camera.K)[None],
        width=camera.width,
        height=camera.height,
        near_plane=config.near,
        far_plane=config.far,
        eps2d=config.low_pass,
        sh_degree=scene.sh_degree if values is None else None,
        tile_size=config.tile_size,
        render_mode="RGB",
        rasterize_mode="classic",
    )
    image = out[0].detach().cpu().numpy().astype(np.float32)
    return np.clip(image, 0.0, 1.0) if values is None else image
