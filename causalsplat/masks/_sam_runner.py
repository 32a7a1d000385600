"""The torch side of :mod:`causalsplat.masks.generate`: the checkpoint, the model and its
automatic mask generator, through the public APIs of ``segment_anything`` and ``sam2``.

The model is built with random weights, the checkpoint's weights are compared with it
(names and shapes) and then loaded, so a checkpoint of another architecture is one line
that says what does not fit, before any image is segmented.
"""

from __future__ import annotations

import re
import warnings
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import torch

from causalsplat.masks._torchvision_stand_in import stand_in_modules
from causalsplat.masks.generate import (
    SAM2_CONFIGS,
    CheckpointError,
    GenerateConfig,
    MaskGenerateError,
)
from causalsplat.masks.rle import encode_rle

#: SAM's image-encoder width (the last axis of ``image_encoder.pos_embed``) -> model name.
_SAM_WIDTHS = {768: "vit_b", 1024: "vit_l", 1280: "vit_h"}

#: A generator: an (H, W, 3) uint8 RGB image -> its annotations, ready for JSON.
Generator = Callable[[np.ndarray], list[dict[str, Any]]]


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


def _unreadable(path: Path, exc: Exception) -> CheckpointError:
    """One line for what ``torch.load(weights_only=True)`` raised on ``path``."""
    text = str(exc)
    unsafe = re.search(r"Unsupported global: GLOBAL (\S+)", text)
    if unsafe:
        return CheckpointError(
            f"checkpoint {path} holds more than weights ({unsafe[1]}, which loading weights"
            " only refuses): save its state dict, torch.save(model.state_dict(), path)"
        )
    detail = text.partition("WeightsUnpickler error:")[2].strip() or text.strip()
    detail = detail.splitlines()[0] if detail else ""
    detail = ": ".join(dict.fromkeys([type(exc).__name__, detail or type(exc).__name__]))
    return CheckpointError(f"checkpoint {path} is not a PyTorch weights file ({detail})")


def read_state_dict(path: Path) -> dict[str, torch.Tensor]:
    """The weights of a checkpoint: a state dict, or SAM 2's ``{"model": state dict}``.

    Loaded with ``weights_only=True`` (tensors and plain containers, no code)."""
    try:
        with warnings.catch_warnings():  # e.g. about the pickle protocol of a foreign file
            warnings.simplefilter("ignore")
            document = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # torch.load fails in many ways on a file that is not one
        raise _unreadable(path, exc) from exc
    if isinstance(document, Mapping) and isinstance(document.get("model"), Mapping):
        document = document["model"]
    if not (
        isinstance(document, Mapping)
        and document
        and all(isinstance(k, str) and isinstance(v, torch.Tensor) for k, v in document.items())
    ):
        raise CheckpointError(f"checkpoint {path} holds no state dict (names -> tensors)")
    return dict(document)


def _shape(tensor: torch.Tensor) -> list[int]:
    return list(tensor.shape)


def _guess(model: str, state: Mapping[str, torch.Tensor]) -> str:
    """What the checkpoint looks like, when that is not ``model``."""
    if "maskmem_tpos_enc" in state:
        return "" if model in SAM2_CONFIGS else "; it looks like a SAM 2 checkpoint"
    pos = state.get("image_encoder.pos_embed")
    guess = _SAM_WIDTHS.get(int(pos.shape[-1])) if pos is not None and pos.ndim == 4 else None
    return f"; it looks like a {guess} checkpoint" if guess and guess != model else ""


def fit_state_dict(
    net: torch.nn.Module, state: Mapping[str, torch.Tensor], model: str, path: Path
) -> None:
    """Load ``state`` into ``net``, or raise :class:`CheckpointError` saying in one line
    which weights are missing, unexpected or of another shape."""
    own = net.state_dict()
    missing = [k for k in own if k not in state]
    unexpected = [k for k in state if k not in own]
    reshaped = [k for k in own if k in state and state[k].shape != own[k].shape]
    problems = []
    if reshaped:
        k = reshaped[0]
        problems.append(f"{len(reshaped)} of another shape (e.g. {k}: {_shape(state[k])} in"
                        f" the checkpoint, {_shape(own[k])} in {model})")  # fmt: skip
    if missing:
        problems.append(f"{len(missing)} missing (e.g. {missing[0]})")
    if unexpected:
        problems.append(f"{len(unexpected)} unexpected (e.g. {unexpected[0]})")
    if problems:
        raise CheckpointError(
            f"checkpoint {path} ({len(state)} weights) does not fit model {model}: "
            + ", ".join(problems) + _guess(model, state)
        )  # fmt: skip
    try:
        net.load_state_dict(state, strict=True)
    except RuntimeError as exc:  # e.g. a dtype torch cannot copy
        raise CheckpointError(
            f"checkpoint {path} does not fit model {model}: {_first_line(exc)}"
        ) from exc


def _device(name: str) -> torch.device:
    try:
        device = torch.device(name)
        torch.empty(0, device=device)
    except (RuntimeError, ValueError, AssertionError) as exc:
        raise MaskGenerateError(f"device {name!r} cannot be used: {_first_line(exc)}") from exc
    return device


def _plain(value: Any) -> Any:
    """A generator's number or list as JSON-ready Python values."""
    if isinstance(value, np.ndarray | torch.Tensor):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    return value


def _annotation(ann: Mapping[str, Any]) -> dict[str, Any]:
    """One annotation as SAM's ``amg.py --convert-to-rle`` writes it."""
    return {
        "segmentation": encode_rle(ann["segmentation"]),
        "area": int(ann["area"]),
        "bbox": _plain(ann["bbox"]),
        "predicted_iou": float(ann["predicted_iou"]),
        "point_coords": _plain(ann["point_coords"]),
        "stability_score": float(ann["stability_score"]),
        "crop_box": _plain(ann["crop_box"]),
    }


def _build(model: str) -> tuple[torch.nn.Module, type]:
    """The model with random weights, and its automatic mask generator class."""
    with stand_in_modules():
        if model in SAM2_CONFIGS:
            from sam2.automatic_mask_generator import SAM2AutomaticMaskGenerator
            from sam2.build_sam import build_sam2

            net = build_sam2(SAM2_CONFIGS[model], None, device="cpu", apply_postprocessing=False)
            return net, SAM2AutomaticMaskGenerator
        from segment_anything import SamAutomaticMaskGenerator, sam_model_registry

        return sam_model_registry[model](), SamAutomaticMaskGenerator


def load_generator(model: str, checkpoint: Path, config: GenerateConfig, device: str) -> Generator:
    """The automatic mask generator of ``model`` with the weights of ``checkpoint``."""
    where = _device(device)
    state = read_state_dict(checkpoint)
    net, generator_class = _build(model)
    fit_state_dict(net, state, model, checkpoint)
    del state
    net = net.to(where).eval()
    generator = generator_class(
        net,
        points_per_side=config.points_per_side,
        points_per_batch=config.points_per_batch,
        pred_iou_thresh=config.pred_iou_thresh,
        stability_score_thresh=config.stability_score_thresh,
        box_nms_thresh=config.box_nms_thresh,
        crop_n_layers=config.crop_n_layers,
        min_mask_region_area=config.min_mask_region_area,
        output_mode="binary_mask",
    )

    def generate(image: np.ndarray) -> list[dict[str, Any]]:
        with torch.inference_mode():
            return [_annotation(ann) for ann in generator.generate(image)]

    return generate
