"""The :class:`MaskSet` type: the 2D masks of one view, with optional labels and scores."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from causalsplat.errors import InputFormatError


class MaskFormatError(InputFormatError):
    """A mask set (in memory or a ``masks/<stem>.npz`` file) is malformed.

    The message names the file or view and the offending key, dtype, shape or count.
    """


def _frozen(arr: np.ndarray) -> np.ndarray:
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True, slots=True, eq=False)
class MaskSet:
    """The masks of one view (``masks/<image stem>.npz``, docs/formats.md).

    Attributes:
        view: the view's image stem (``images/<view>.png`` ↔ ``masks/<view>.npz``).
        masks: (M, H, W) bool, one binary mask per segment, image pixel grid (row, column).
            M may be 0. Masks may overlap (SAM output does); GT masks from an id render don't.
        labels: M category names (one per mask), or ``None`` when the masks are unlabelled.
        scores: (M,) float32 confidence per mask (SAM's predicted IoU), or ``None``.
        ids: (M,) int64 instance id each mask was made from (GT masks only), or ``None``.

    Arrays are copied and made read-only; shapes, dtypes and counts are checked and a
    mismatch raises :class:`MaskFormatError` naming the view.
    """

    view: str
    masks: np.ndarray
    labels: tuple[str, ...] | None = None
    scores: np.ndarray | None = None
    ids: np.ndarray | None = None

    def __post_init__(self) -> None:
        where = f"mask set of view {self.view!r}"
        masks = np.asarray(self.masks)
        if masks.dtype != np.bool_:
            raise MaskFormatError(f"{where}: masks have dtype {masks.dtype}; expected bool")
        if masks.ndim != 3:
            raise MaskFormatError(f"{where}: masks have shape {masks.shape}; expected (M, H, W)")
        m = masks.shape[0]
        object.__setattr__(self, "masks", _frozen(np.array(masks, dtype=bool, copy=True)))
        if self.labels is not None:
            labels = tuple(self.labels)
            if len(labels) != m:
                raise MaskFormatError(f"{where}: {len(labels)} labels for {m} masks")
            for label in labels:
                if not isinstance(label, str):
                    raise MaskFormatError(f"{where}: label {label!r} is not a string")
            object.__setattr__(self, "labels", labels)
        if self.scores is not None:
            scores = np.asarray(self.scores)
            if scores.dtype.kind not in "fiu" or scores.shape != (m,):
                raise MaskFormatError(
                    f"{where}: scores have dtype {scores.dtype} and shape {scores.shape}; "
                    f"expected ({m},) float"
                )
            if not np.all(np.isfinite(scores)):
                raise MaskFormatError(f"{where}: scores contain NaN or Inf")
            object.__setattr__(self, "scores", _frozen(scores.astype(np.float32)))
        if self.ids is not None:
            ids = np.asarray(self.ids)
            if ids.dtype.kind not in "iu" or ids.shape != (m,):
                raise MaskFormatError(
                    f"{where}: ids have dtype {ids.dtype} and shape {ids.shape}; "
                    f"expected ({m},) int"
                )
            object.__setattr__(self, "ids", _frozen(ids.astype(np.int64)))

    @property
    def n(self) -> int:
        """Number of masks M."""
        return int(self.masks.shape[0])

    @property
    def height(self) -> int:
        return int(self.masks.shape[1])

    @property
    def width(self) -> int:
        return int(self.masks.shape[2])

    def equals(self, other: MaskSet) -> bool:
        """True when both sets hold the same view, masks, labels, scores and ids."""

        def same(a: np.ndarray | None, b: np.ndarray | None) -> bool:
            if a is None or b is None:
                return a is None and b is None
            return a.shape == b.shape and bool(np.array_equal(a, b))

        return (
            self.view == other.view
            and same(self.masks, other.masks)
            and self.labels == other.labels
            and same(self.scores, other.scores)
            and same(self.ids, other.ids)
        )

    def select(self, keep: Sequence[int] | np.ndarray) -> MaskSet:
        """The masks at indices ``keep`` (in that order), with their labels, scores and ids."""
        index = np.asarray(keep, dtype=np.int64).reshape(-1)
        return MaskSet(
            view=self.view,
            masks=self.masks[index],
            labels=None if self.labels is None else tuple(self.labels[i] for i in index),
            scores=None if self.scores is None else self.scores[index],
            ids=None if self.ids is None else self.ids[index],
        )


def masks_from_id_render(
    id_map: np.ndarray, labels_by_id: Mapping[int, str] | None, *, view: str = ""
) -> MaskSet:
    """GT masks from an instance-id render: one mask per id present, ids ascending.

    Args:
        id_map: (H, W) integer id per pixel, ``-1`` (any negative value) = background.
        labels_by_id: category name of each id, or ``None`` for unlabelled masks.
        view: the view name stored in the result.

    Returns a :class:`MaskSet` with disjoint masks, ``ids`` set and no scores.
    Raises :class:`MaskFormatError` for a non-integer or non-2D map, or an id without a label.
    """
    ids_img = np.asarray(id_map)
    if ids_img.ndim != 2 or ids_img.dtype.kind not in "iu":
        raise MaskFormatError(
            f"id render of view {view!r}: dtype {ids_img.dtype}, shape {ids_img.shape}; "
            "expected (H, W) int"
        )
    present = np.unique(ids_img[ids_img >= 0]).astype(np.int64)
    masks = ids_img[None, :, :] == present[:, None, None]
    labels = None
    if labels_by_id is not None:
        missing = [int(i) for i in present if int(i) not in labels_by_id]
        if missing:
            raise MaskFormatError(f"id render of view {view!r}: no label for id(s) {missing}")
        labels = tuple(labels_by_id[int(i)] for i in present)
    return MaskSet(view=view, masks=masks, labels=labels, ids=present)


def id_map_from_masks(maskset: MaskSet) -> np.ndarray:
    """The (H, W) int64 id map of a GT mask set (inverse of :func:`masks_from_id_render`).

    Pixels covered by no mask are ``-1``. Raises :class:`MaskFormatError` when the set has
    no ids or its masks overlap.
    """
    if maskset.ids is None:
        raise MaskFormatError(f"mask set of view {maskset.view!r} has no ids")
    if maskset.n and int(maskset.masks.sum(axis=0).max()) > 1:
        raise MaskFormatError(f"mask set of view {maskset.view!r}: masks overlap")
    out = np.full((maskset.height, maskset.width), -1, dtype=np.int64)
    for mask, instance in zip(maskset.masks, maskset.ids, strict=True):
        out[mask] = instance
    return out
