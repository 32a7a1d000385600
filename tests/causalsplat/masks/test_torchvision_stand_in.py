"""The torchvision stand-ins SAM and SAM 2 are imported with where torchvision does not work."""

from __future__ import annotations

import sys

import numpy as np
import pytest

torch = pytest.importorskip("torch")
from causalsplat.masks import _torchvision_stand_in as tv  # noqa: E402
from causalsplat.masks._torchvision_stand_in import (  # noqa: E402
    Normalize,
    Resize,
    ToTensor,
    batched_nms,
    box_area,
    resize,
    to_pil_image,
)


def _random_boxes(rng: np.random.Generator, n: int) -> torch.Tensor:
    xy = rng.uniform(0, 50, (n, 2))
    wh = rng.uniform(1, 30, (n, 2))
    return torch.as_tensor(np.concatenate([xy, xy + wh], axis=1), dtype=torch.float32)


def _iou(a: torch.Tensor, b: torch.Tensor) -> float:
    w = min(a[2], b[2]) - max(a[0], b[0])
    h = min(a[3], b[3]) - max(a[1], b[1])
    inter = float(max(w, 0) * max(h, 0))
    return inter / (float(box_area(a[None])[0] + box_area(b[None])[0]) - inter)


def test_nms_by_hand() -> None:
    boxes = torch.tensor([[0.0, 0, 10, 10], [1, 1, 10, 10], [20, 20, 30, 30], [0, 0, 10, 9]])
    scores = torch.tensor([0.8, 0.9, 0.7, 0.6])
    assert box_area(boxes).tolist() == [100.0, 81.0, 100.0, 90.0]
    # box 1 (best) drops box 0 (IoU 0.81) and box 3 (IoU 0.81/0.9 = 0.72... of 90+81-72)
    assert batched_nms(boxes, scores, torch.zeros(4), 0.5).tolist() == [1, 2]
    # in categories of their own nothing is dropped; order is by score
    assert batched_nms(boxes, scores, torch.arange(4), 0.5).tolist() == [1, 0, 2, 3]
    assert batched_nms(boxes[:0], scores[:0], torch.zeros(0), 0.5).tolist() == []


@pytest.mark.parametrize("threshold", [0.0, 0.3, 0.7, 1.0])
def test_nms_keeps_what_greedy_suppression_keeps(threshold: float) -> None:
    """The defining properties: kept boxes of one category overlap each other by at most
    the threshold, every dropped box overlaps a kept box of its category with a higher score
    by more, and the result is sorted by score."""
    rng = np.random.default_rng(int(threshold * 10))
    boxes = _random_boxes(rng, 80)
    scores = torch.as_tensor(rng.random(80), dtype=torch.float32)
    cats = torch.as_tensor(rng.integers(0, 3, 80))
    kept = batched_nms(boxes, scores, cats, threshold).tolist()
    assert kept == sorted(kept, key=lambda i: -float(scores[i]))
    for a in kept:
        for b in kept:
            if a < b and cats[a] == cats[b]:
                assert _iou(boxes[a], boxes[b]) <= threshold
    for d in set(range(80)) - set(kept):
        assert any(
            cats[k] == cats[d] and scores[k] > scores[d] and _iou(boxes[k], boxes[d]) > threshold
            for k in kept
        )
    if threshold == 0.0:  # any overlap suppresses: random boxes overlap often
        assert len(kept) < 60


def test_nms_matches_torchvision_where_it_works() -> None:
    if not tv.torchvision_works():
        pytest.skip("torchvision does not import here (PyPI's wheels need CUDA torch)")
    from torchvision.ops import batched_nms as theirs

    rng = np.random.default_rng(5)
    boxes, scores = _random_boxes(rng, 200), torch.as_tensor(rng.random(200), dtype=torch.float32)
    cats = torch.as_tensor(rng.integers(0, 4, 200))
    assert (
        batched_nms(boxes, scores, cats, 0.5).tolist() == theirs(boxes, scores, cats, 0.5).tolist()
    )


@pytest.mark.filterwarnings("ignore:`torch.jit.script` is deprecated:DeprecationWarning")
def test_image_transforms_match_pillow() -> None:
    from PIL import Image

    rng = np.random.default_rng(2)
    image = (rng.random((30, 40, 3)) * 255).astype(np.uint8)
    small = resize(to_pil_image(image), (15, 20))
    assert small.size == (20, 15)
    assert np.array_equal(
        np.asarray(small),
        np.asarray(Image.fromarray(image).resize((20, 15), Image.Resampling.BILINEAR)),
    )
    tensor = ToTensor()(image)
    assert tensor.shape == (3, 30, 40) and tensor.dtype == torch.float32
    assert torch.allclose(
        tensor[:, 3, 7], torch.as_tensor(image[3, 7] / 255.0, dtype=torch.float32)
    )
    # SAM 2 scripts Resize + Normalize; an antialiased bilinear resize is pillow's within 1 level
    script = torch.jit.script(
        torch.nn.Sequential(Resize((15, 20)), Normalize([0.5] * 3, [0.25] * 3))
    )
    ours = script(tensor) * 0.25 + 0.5
    assert ours.shape == (3, 15, 20)
    pillow = ToTensor()(Image.fromarray(image).resize((20, 15), Image.Resampling.BILINEAR))
    assert float((ours - pillow).abs().max()) < 2 / 255


def test_stand_ins_are_seen_only_inside_the_block(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(tv, "torchvision_works", lambda: False)
    before = {k: v for k, v in sys.modules.items() if k.partition(".")[0] == "torchvision"}
    with tv.stand_in_modules():
        import torchvision
        from torchvision.ops.boxes import batched_nms as imported
        from torchvision.transforms.functional import resize as imported_resize

        assert imported is batched_nms and imported_resize is resize
        assert torchvision.transforms.Resize is Resize
    after = {k: v for k, v in sys.modules.items() if k.partition(".")[0] == "torchvision"}
    assert after == before
