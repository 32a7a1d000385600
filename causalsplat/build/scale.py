"""Working at a fraction of the masks' resolution (``BuildConfig.image_scale``).

A view at scale ``s`` has ``round(s * W) x round(s * H)`` pixels and intrinsics scaled by
the same per-axis ratios (pixel centres stay at half-integers, so ``c' = c * W' / W``).
Its masks are reduced by area: a pixel of the smaller grid belongs to a mask when the mask
covers *more than half* of the source area under it (a box filter, then a strict majority),
so thin parts vanish as they would in a smaller image and no mask grows. The majority is
strict so that two masks sharing no pixel never share one after the reduction: their
shares of a pixel sum to at most 1, and a pixel split half and half goes to neither. With
"at least half" every tie on a boundary between neighbouring masks went to both, and the
training treats masks that share a pixel as parts of one another, never pushing them
apart: on a synthetic room at 640x480 reduced to 320x240, exact (disjoint) masks came
out with 1,356 overlapping pairs, and neighbouring objects merged (docs/benchmarks.md,
"Masks reduced by a strict majority"). Every stage after the folder read sees only the
scaled views; the rasterizer's work and the views' memory fall with ``s ** 2``.

>>> import numpy as np
>>> from causalsplat.masks import MaskSet
>>> m = np.zeros((1, 4, 4), dtype=bool); m[0, :2, :] = True; m[0, 2, 0] = True
>>> scale_masks(MaskSet("v", m), 2, 2).masks[0].astype(int).tolist()
[[1, 1], [0, 0]]
>>> m = np.zeros((2, 2, 2), dtype=bool); m[0, :, 0] = True; m[1, :, 1] = True
>>> scale_masks(MaskSet("v", m), 1, 1).masks.ravel().tolist()  # half and half: neither
[False, False]
"""

from __future__ import annotations

import dataclasses

import numpy as np

from causalsplat.build.folder import SceneFolder
from causalsplat.build.mask_files import MaskFiles
from causalsplat.io.types import Camera
from causalsplat.masks.types import MaskSet

# A share of a target pixel's source area, above one half by more than the box filter's
# float32 rounding (about 1e-7): a true half never passes, whatever the scale.
_MAJORITY = 0.5 + 1e-6


def scaled_size(width: int, height: int, scale: float) -> tuple[int, int]:
    """The pixel size of a ``width`` x ``height`` view at ``scale`` (at least 1 x 1)."""
    return max(1, round(width * scale)), max(1, round(height * scale))


def scale_camera(camera: Camera, scale: float) -> Camera:
    """``camera`` with its image ``scale`` times as wide and high (module docstring)."""
    width, height = scaled_size(camera.width, camera.height, scale)
    sx, sy = width / camera.width, height / camera.height
    return dataclasses.replace(
        camera, width=width, height=height, fx=camera.fx * sx, fy=camera.fy * sy,
        cx=camera.cx * sx, cy=camera.cy * sy,
    )  # fmt: skip


def scale_masks(maskset: MaskSet, width: int, height: int) -> MaskSet:
    """``maskset`` on a ``width`` x ``height`` grid, reduced by area (module docstring)."""
    from PIL import Image

    if maskset.n == 0:
        masks = np.zeros((0, height, width), dtype=bool)
    else:
        masks = np.stack([
            np.asarray(
                Image.fromarray(m.astype(np.float32)).resize((width, height), Image.Resampling.BOX)
            ) > _MAJORITY
            for m in maskset.masks
        ])  # fmt: skip
    return dataclasses.replace(maskset, masks=masks)


def scale_folder(folder: SceneFolder, scale: float, mask_budget: int) -> SceneFolder:
    """``folder`` as seen at ``scale``: scaled cameras, masks reduced when read."""
    if scale == 1.0:
        return folder
    cameras = tuple(scale_camera(c, scale) for c in folder.cameras)
    source = folder.masks

    def read(i: int) -> MaskSet:
        return scale_masks(source[i], cameras[i].width, cameras[i].height)

    masks = MaskFiles(len(cameras), read, mask_budget)
    return dataclasses.replace(folder, cameras=cameras, masks=masks)
