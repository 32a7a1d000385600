"""The masks of a scene folder's views, read from their files when a stage asks for them.

A view's masks are an (M, H, W) bool array: 75 MB for 100 masks of a 1000x750 view, so a
200-view capture held whole would take 15 GB. :class:`MaskFiles` is the sequence of a
folder's :class:`~causalsplat.masks.MaskSet` (``masks[i]`` of ``cameras[i]``) that keeps
the views it has read in memory up to a byte budget, least recently used first out, and
reads a view's file again when it is asked for after being dropped. Every file is read
and checked once when the folder is opened, so a malformed file is refused before any
expensive stage runs. Views are visited in order by every stage, so a budget of one view
already reads each file once per stage.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Callable

from causalsplat.field.spill import PerView
from causalsplat.masks.types import MaskSet

#: Default byte budget of the views kept in memory.
DEFAULT_BUDGET = 1 << 30


class MaskFiles(PerView[MaskSet]):
    """Lazily read mask sets (module docstring). ``read(i)`` reads and checks view ``i``."""

    def __init__(
        self, count: int, read: Callable[[int], MaskSet], budget_bytes: int = DEFAULT_BUDGET
    ) -> None:
        self._count = count
        self._read = read
        self._budget = int(budget_bytes)
        self._kept: OrderedDict[int, MaskSet] = OrderedDict()
        self._bytes = 0
        self.reads = 0
        for i in range(count):  # check every file now; keep what fits
            self[i]

    def __len__(self) -> int:
        return self._count

    def _view(self, index: int) -> MaskSet:
        hit = self._kept.get(index)
        if hit is not None:
            self._kept.move_to_end(index)
            return hit
        value = self._read(index)
        self.reads += 1
        self._kept[index] = value
        self._bytes += value.masks.nbytes
        while self._bytes > self._budget and len(self._kept) > 1:
            _, old = self._kept.popitem(last=False)
            self._bytes -= old.masks.nbytes
        return value
