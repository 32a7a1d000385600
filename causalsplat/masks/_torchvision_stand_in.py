"""The few torchvision functions SAM and SAM 2 import, for a process without a working torchvision.

PyPI's torchvision wheels for Linux are built against the CUDA build of torch; next to the
CPU build this project pins, ``import torchvision`` fails (its compiled operators cannot be
loaded). SAM's automatic mask generator only needs box non-maximum suppression, box areas
and a pillow resize from it (SAM 2 also three image transforms), so :func:`stand_in_modules`
provides those, written on torch and pillow, while ``segment_anything`` / ``sam2`` are
imported; the modules are taken out of :data:`sys.modules` again afterwards, so nothing else
in the process sees them. Where torchvision imports, it is used as it is.

"""

from __future__ import annotations

import functools
import importlib
import sys
import types
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np
import torch
from torch import nn
from torch.nn import functional as F


def box_area(boxes: torch.Tensor) -> torch.Tensor:
    """(N,) areas of (N, 4) boxes ``x0, y0, x1, y1`` (torchvision's convention: no +1)."""
    return (boxes[:, 2] - boxes[:, 0]) * (boxes[:, 3] - boxes[:, 1])


def _iou_matrix(boxes: torch.Tensor) -> torch.Tensor:
    area = box_area(boxes)
    top_left = torch.maximum(boxes[:, None, :2], boxes[None, :, :2])
    bottom_right = torch.minimum(boxes[:, None, 2:], boxes[None, :, 2:])
    inter = (bottom_right - top_left).clamp(min=0).prod(dim=2)
    return inter / (area[:, None] + area[None, :] - inter)


def batched_nms(
    boxes: torch.Tensor, scores: torch.Tensor, idxs: torch.Tensor, iou_threshold: float
) -> torch.Tensor:
    """Greedy non-maximum suppression within each category of ``idxs``.

    Returns the int64 indices of the boxes kept, highest score first: a box is dropped
    when its IoU with a kept box of the same category and higher score exceeds
    ``iou_threshold``.
    """
    if boxes.numel() == 0:
        return torch.empty((0,), dtype=torch.int64, device=boxes.device)
    order = torch.sort(scores, descending=True, stable=True).indices
    boxes64 = boxes.detach().to("cpu", torch.float64)[order]
    iou = _iou_matrix(boxes64).numpy()
    same = (idxs[order][:, None] == idxs[order][None, :]).cpu().numpy()
    overlaps = (iou > iou_threshold) & same
    dropped = np.zeros(len(order), dtype=bool)
    kept = []
    for i in range(len(order)):
        if not dropped[i]:
            kept.append(i)
            dropped |= overlaps[i]
    return order[torch.as_tensor(kept, dtype=torch.int64)].to(boxes.device)


def to_pil_image(image: np.ndarray) -> Any:
    """An ``(H, W, 3)`` uint8 RGB array as a pillow image."""
    from PIL import Image

    return Image.fromarray(np.ascontiguousarray(image))


def resize(image: Any, size: list[int] | tuple[int, int]) -> Any:
    """A pillow image resized bilinearly to ``size`` = ``(height, width)``."""
    from PIL import Image

    height, width = size
    return image.resize((int(width), int(height)), Image.Resampling.BILINEAR)


class ToTensor:
    """An ``(H, W, C)`` uint8 array (or pillow image) as a ``(C, H, W)`` float tensor in [0, 1]."""

    def __call__(self, image: Any) -> torch.Tensor:
        array = np.array(image, dtype=np.uint8, copy=True)
        if array.ndim == 2:
            array = array[:, :, None]
        return torch.from_numpy(array).permute(2, 0, 1).float().div(255.0)


class Resize(nn.Module):
    """A ``(C, H, W)`` float tensor resized bilinearly (antialiased) to ``size``."""

    def __init__(self, size: tuple[int, int]) -> None:
        super().__init__()
        self.size = [int(size[0]), int(size[1])]

    def forward(self, image: torch.Tensor) -> torch.Tensor:
        batch = image.unsqueeze(0)
        out = F.interpolate(batch, size=self.size, mode="bilinear", align_corners=False,
                            antialias=True)  # fmt: skip
        return out.squeeze(0)


class Normalize(nn.Module):
    """``(image - mean) / std`` per channel of a ``(C, H, W)`` tensor."""

    def __init__(self, mean: list[float], std: list[float]) -> None:
        super().__init__()
        self.register_buffer("mean", torch.tensor(mean).view(-1, 1, 1), persistent=False)
        self.register_buffer("std", torch.tensor(std).view(-1, 1, 1), persistent=False)

    def forward(self, image: torch.Tensor) -> torch.Tensor:
        return (image - self.mean) / self.std


def _modules() -> dict[str, types.ModuleType]:
    boxes = {"batched_nms": batched_nms, "box_area": box_area}
    members: dict[str, dict[str, Any]] = {
        "torchvision": {},
        "torchvision.ops": dict(boxes),
        "torchvision.ops.boxes": dict(boxes),
        "torchvision.transforms": {"Normalize": Normalize, "Resize": Resize,
                                   "ToTensor": ToTensor},
        "torchvision.transforms.functional": {"resize": resize, "to_pil_image": to_pil_image},
    }  # fmt: skip
    made = {}
    for name, names in members.items():
        module = types.ModuleType(name, "a stand-in of causalsplat.masks._torchvision_stand_in")
        module.__dict__.update(names)
        made[name] = module
    for name, module in made.items():  # each submodule is an attribute of its parent
        parent, _, leaf = name.rpartition(".")
        if parent:
            setattr(made[parent], leaf, module)
    return made


@functools.cache
def torchvision_works() -> bool:
    """True when ``import torchvision`` succeeds in this process (tried once)."""
    try:
        importlib.import_module("torchvision.ops.boxes")
        importlib.import_module("torchvision.transforms.functional")
    except Exception:  # an ImportError, or a RuntimeError from its compiled operators
        return False
    return True


@contextmanager
def stand_in_modules() -> Iterator[None]:
    """Inside the block, ``import torchvision`` finds the stand-ins of this module, unless
    the real torchvision works; the process's modules are restored on leaving."""
    if torchvision_works():
        yield
        return
    saved = {k: v for k, v in sys.modules.items() if k.partition(".")[0] == "torchvision"}
    for name in saved:
        del sys.modules[name]
    sys.modules.update(_modules())
    try:
        yield
    finally:
        for name in [k for k in sys.modules if k.partition(".")[0] == "torchvision"]:
            del sys.modules[name]
        sys.modules.update(saved)
