"""Labelling entities from their mask crops with a labeller (the VLM one of the method).

For each entity the view where its largest clustered mask lies is chosen; the crop is the
mask's bounding box (padded by ``pad`` px) of that view's image, pixels outside the mask
set to mid grey, as the method sends them. The labeller (anything with
``label_crops(crops, hints=...)`` returning objects with ``category``, ``to_attributes()``,
e.g. :class:`~causalsplat.openai_compat.VLMLabeler`) names each crop; the mask vote is
passed as a hint. The entity keeps its geometry and geometric attributes; its category
and the labeller's attributes (source ``vlm``) replace the mask-vote ones.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from typing import Any, Protocol

import numpy as np

from causalsplat.field.types import MaskEvidence
from causalsplat.instances.assign import InstanceAssignment
from causalsplat.masks import MaskSet
from graph_store import AttributeSource, Entity

GREY = 127


class Labeler(Protocol):
    def label_crops(self, crops: Sequence[np.ndarray], *, hints: Sequence[str | None] | None
                    = None) -> Sequence[Any]: ...  # fmt: skip


def best_masks(assignment: InstanceAssignment, evidence: MaskEvidence) -> dict[int, int]:
    """Entity id -> row of its largest assigned mask (by summed pixel weight)."""
    best: dict[int, int] = {}
    for row, k in enumerate(assignment.mask_entity.tolist()):
        if k >= 0 and (
            k not in best or evidence.pixel_weight[row] > evidence.pixel_weight[best[k]]
        ):
            best[k] = row
    return best


def crop_masked(image: np.ndarray, mask: np.ndarray, pad: int = 4) -> np.ndarray:
    """(h, w, 3) uint8: the mask's padded bounding box, outside the mask mid grey."""
    rows, cols = np.nonzero(mask)
    if rows.size == 0:
        raise ValueError("crop_masked: empty mask")
    r0, r1 = max(rows.min() - pad, 0), min(rows.max() + pad + 1, mask.shape[0])
    c0, c1 = max(cols.min() - pad, 0), min(cols.max() + pad + 1, mask.shape[1])
    img = np.asarray(image)
    if img.dtype != np.uint8:
        img = np.clip(np.asarray(img, dtype=np.float64) * 255.0 + 0.5, 0, 255).astype(np.uint8)
    out = img[r0:r1, c0:c1, :3].copy()
    out[~mask[r0:r1, c0:c1]] = GREY
    return out


def label_entities(
    entities: Sequence[Entity],
    assignment: InstanceAssignment,
    evidence: MaskEvidence,
    masksets: Sequence[MaskSet],
    image_of_view: Callable[[int], np.ndarray],
    labeler: Labeler,
    *,
    pad: int = 4,
) -> tuple[Entity, ...]:
    """Entities relabelled by ``labeler`` from one crop each (module docstring).

    ``image_of_view(v)`` gives view ``v``'s (H, W, 3) image (uint8, or float in [0, 1]).
    Entities without an assigned mask keep their labels.
    """
    best = best_masks(assignment, evidence)
    todo = [e for e in entities if e.id in best]
    crops, hints = [], []
    for e in todo:
        row = best[e.id]
        view, index = int(evidence.view[row]), int(evidence.index[row])
        crops.append(crop_masked(image_of_view(view), masksets[view].masks[index], pad))
        hints.append(e.category if e.confidence is not None else None)
    labels = labeler.label_crops(crops, hints=hints) if crops else []
    new = {e.id: e for e in entities}
    for e, label in zip(todo, labels, strict=True):
        kept = tuple(a for a in e.attributes if a.source is AttributeSource.GEOMETRY)
        new[e.id] = dataclasses.replace(
            e, category=label.category, confidence=None,
            attributes=tuple(sorted({*kept, *label.to_attributes()})),
        )  # fmt: skip
    return tuple(new[e.id] for e in entities)
