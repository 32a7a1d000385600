"""How closely renders from the real poses resemble the real photos.

For each real frame: the mean absolute RGB error (0-255 scale) between the render and the
photo (resized to the render's size with a box filter), over the pixels the render covers
(accumulated alpha >= 0.5); and the same error for a render whose vertex colours were
shuffled among the Gaussians (same geometry), the baseline a wrong pose or a wrong colour
mapping would score. ``SOURCE.md`` reports about 31 against about 70 for a z-buffered
point projection at full resolution.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from causalsplat.io.types import Camera, GaussianScene


@dataclass(frozen=True, slots=True)
class PhotoCheck:
    """Render-vs-photo error of one real frame.

    Attributes:
        view: the camera name.
        mae: mean absolute RGB error, 0-255 scale, over covered pixels.
        mae_shuffled: the same with shuffled Gaussian colours.
        coverage: fraction of pixels the render covers.
    """

    view: str
    mae: float
    mae_shuffled: float
    coverage: float


def load_photo(path: Path, width: int, height: int) -> np.ndarray:
    """(H, W, 3) uint8 photo resized to ``width x height`` (box filter)."""
    from PIL import Image

    with Image.open(path) as img:
        return np.asarray(img.convert("RGB").resize((width, height), Image.Resampling.BOX))


def check_photos(
    scene: GaussianScene,
    cameras: tuple[Camera, ...],
    photos: tuple[np.ndarray, ...],
    rng: np.random.Generator,
) -> tuple[PhotoCheck, ...]:
    """Compare renders from ``cameras`` with ``photos`` (module docstring)."""
    from causalsplat.render.functional import render_alpha, render_rgb

    perm = rng.permutation(scene.n)
    shuffled = GaussianScene(
        means=scene.means,
        quats=scene.quats,
        log_scales=scene.log_scales,
        opacity_logits=scene.opacity_logits,
        sh=scene.sh[perm],
    )
    out = []
    for cam, photo in zip(cameras, photos, strict=True):
        covered = render_alpha(scene, cam) >= 0.5
        ref = photo.astype(np.float64)
        if not covered.any():
            out.append(PhotoCheck(cam.name, float("nan"), float("nan"), 0.0))
            continue
        err = np.abs(render_rgb(scene, cam) * 255.0 - ref)[covered].mean()
        base = np.abs(render_rgb(shuffled, cam) * 255.0 - ref)[covered].mean()
        out.append(PhotoCheck(cam.name, float(err), float(base), float(covered.mean())))
    return tuple(out)
