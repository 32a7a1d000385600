"""``generate_masks`` with SAM 2 (the ``sam2`` package, not in ``make test``'s extras): a
randomly initialised ``sam2.1_hiera_t``, its smallest configuration, on CPU. Skipped where
``sam2`` is not installed (``pip install -c constraints.txt 'causalsplat[sam2]'``)."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

from causalsplat.masks.convert import decode_rle, read_sam_json
from causalsplat.masks.generate import CheckpointError, GenerateConfig, generate_masks

if any(importlib.util.find_spec(m) is None for m in ("torch", "sam2", "PIL")):
    pytest.skip("sam2 (or torch, pillow) is not installed", allow_module_level=True)

import torch
from PIL import Image

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")  # torch.jit in sam2


def test_sam2_hiera_t_with_random_weights(tmp_path: Path) -> None:
    from causalsplat.masks._torchvision_stand_in import stand_in_modules
    from causalsplat.masks.generate import SAM2_CONFIGS

    with stand_in_modules():
        from sam2.build_sam import build_sam2
    torch.manual_seed(0)
    net = build_sam2(SAM2_CONFIGS["sam2.1_hiera_t"], None, device="cpu")
    checkpoint = tmp_path / "sam2.1_hiera_t_random.pt"
    torch.save({"model": net.state_dict()}, checkpoint)  # as SAM 2's checkpoints hold it
    del net
    images = tmp_path / "images"
    images.mkdir()
    image = np.full((36, 52, 3), (200, 200, 200), np.uint8)
    image[4:20, 6:30] = (180, 20, 20)
    Image.fromarray(image).save(images / "v0.png")
    config = GenerateConfig(points_per_side=4, pred_iou_thresh=0, stability_score_thresh=0)
    report = generate_masks(images, tmp_path / "out", checkpoint, model="sam2.1_hiera_t",
                            config=config)  # fmt: skip
    assert (report.views, report.model) == (1, "sam2.1_hiera_t") and report.masks > 0
    annotations = json.loads((tmp_path / "out" / "v0.json").read_text())
    assert len(annotations) == report.masks
    for ann in annotations:
        mask = decode_rle(ann["segmentation"])
        assert mask.shape == (36, 52) and ann["area"] == int(mask.sum())
    assert read_sam_json(tmp_path / "out" / "v0.json").masks.shape == (report.masks, 36, 52)

    sam_like = tmp_path / "vit_b_like.pth"
    torch.save({"image_encoder.pos_embed": torch.zeros(1, 64, 64, 768)}, sam_like)
    with pytest.raises(CheckpointError, match=r"does not fit model sam2\.1_hiera_t: .*vit_b"):
        generate_masks(images, tmp_path / "out2", sam_like, model="sam2.1_hiera_t")
    assert not (tmp_path / "out2").exists()
