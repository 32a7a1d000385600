"""Per-view data that stays in memory up to a byte budget and is memory-mapped from disk beyond it.

A build reads two things of every view in each of its passes (rasterize, uplift, training,
mask evidence): the view's blending weights (:class:`~causalsplat.render.types.Contributors`,
tens of millions of weights for a 1000x750 view of a large scene) and its weighted masks
(:class:`~causalsplat.field.weights.ViewMasks`). Held all at once they grow with
views x pixels. A :class:`ViewSpill` keeps the views it is given resident while their
bytes fit its budget; the views past it are written once, uncompressed, as ``.npy`` files
to a private folder and memory-mapped when a pass reads them, so such a view occupies
memory only while a pass holds it (the operating system's page cache may keep its pages,
but they are not this process's memory and are dropped under pressure).

Writing costs one pass of the data at disk speed, and reading it back is a sequential read
of each view's arrays (see ``causalsplat bench --only scale`` for the measured costs
against recomputing the weights at each use, :class:`RecomputedWeights`).

>>> import numpy as np
>>> codec = ArrayCodec()
>>> spill = ViewSpill(codec, budget_bytes=8)
>>> spill.append(np.arange(2, dtype=np.int32))      # 8 bytes: resident
>>> spill.append(np.arange(3, dtype=np.int32))      # past the budget: written to disk
>>> [a.tolist() for a in spill], spill.n_spilled
([[0, 1], [0, 1, 2]], 1)
>>> spill.close()
"""

from __future__ import annotations

import shutil
import tempfile
import weakref
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any, Protocol, TypeVar, overload

import numpy as np
import scipy.sparse as sp

from causalsplat.field.weights import ViewMasks
from causalsplat.io.types import Camera, GaussianScene
from causalsplat.render.config import RasterConfig
from causalsplat.render.types import Contributors

T = TypeVar("T")
Meta = dict[str, Any]


class Codec(Protocol[T]):
    """How a value becomes named arrays plus small metadata, and back."""

    def encode(self, value: T) -> tuple[dict[str, np.ndarray], Meta]: ...

    def decode(self, arrays: dict[str, np.ndarray], meta: Meta) -> T: ...


class ArrayCodec:
    """A plain array (the doctest's codec)."""

    def encode(self, value: np.ndarray) -> tuple[dict[str, np.ndarray], Meta]:
        return {"a": value}, {}

    def decode(self, arrays: dict[str, np.ndarray], meta: Meta) -> np.ndarray:
        return arrays["a"]


class ContributorsCodec:
    """:class:`Contributors`: its four arrays; sizes and key as metadata."""

    def encode(self, c: Contributors) -> tuple[dict[str, np.ndarray], Meta]:
        arrays = {"indptr": c.indptr, "indices": c.indices, "weights": c.weights}
        arrays["depths"] = c.depths
        return arrays, {"width": c.width, "height": c.height, "n": c.n_gaussians, "key": c.key}

    def decode(self, a: dict[str, np.ndarray], meta: Meta) -> Contributors:
        return Contributors(
            width=meta["width"], height=meta["height"], n_gaussians=meta["n"],
            indptr=a["indptr"], indices=a["indices"], weights=a["weights"],
            depths=a["depths"], key=meta["key"],
        )  # fmt: skip


class ViewMasksCodec:
    """:class:`ViewMasks`: the CSR arrays of its weights, its mask indices and pixels."""

    def encode(self, v: ViewMasks) -> tuple[dict[str, np.ndarray], Meta]:
        w = v.weights
        arrays = {"data": w.data, "indices": w.indices, "indptr": w.indptr}
        arrays.update(mask_index=v.mask_index, pixels=v.pixels)
        return arrays, {"view": v.view, "n_pixels": v.n_pixels, "shape": w.shape}

    def decode(self, a: dict[str, np.ndarray], meta: Meta) -> ViewMasks:
        weights = sp.csr_matrix((a["data"], a["indices"], a["indptr"]), shape=meta["shape"])
        return ViewMasks(meta["view"], a["mask_index"], weights, a["pixels"], meta["n_pixels"])


def _nbytes(arrays: dict[str, np.ndarray]) -> int:
    return sum(int(a.nbytes) for a in arrays.values())


class PerView(Sequence[T]):
    """A read-only sequence of per-view values made when indexed: a subclass gives
    ``__len__`` and ``_view(i)`` for ``0 <= i < len``; indexing (negative, slices, range
    checks) and iteration are here."""

    def _view(self, index: int) -> T:
        raise NotImplementedError

    @overload
    def __getitem__(self, index: int) -> T: ...

    @overload
    def __getitem__(self, index: slice) -> Sequence[T]: ...

    def __getitem__(self, index: int | slice) -> T | Sequence[T]:
        if isinstance(index, slice):
            return [self._view(i) for i in range(*index.indices(len(self)))]
        n = len(self)
        i = index + n if index < 0 else index
        if not 0 <= i < n:
            raise IndexError(f"view {index} out of range ({n} views)")
        return self._view(i)

    def __iter__(self) -> Iterator[T]:
        for i in range(len(self)):
            yield self._view(i)


class ViewSpill(PerView[T]):
    """An append-only sequence of per-view values, resident up to ``budget_bytes`` and
    memory-mapped from ``folder`` (default: a new private folder under the system's
    temporary directory, removed by :meth:`close` or when the spill is collected) beyond;
    with ``disk_bytes``, views that would take the files past it are not kept at all and
    ``rebuild(index)`` makes them again at each use.

    Values read back from disk are read-only views of the mapped files.
    """

    def __init__(
        self,
        codec: Codec[T],
        budget_bytes: int,
        folder: str | Path | None = None,
        *,
        disk_bytes: int | None = None,
        rebuild: Callable[[int], T] | None = None,
    ) -> None:
        if disk_bytes is not None and rebuild is None:
            raise ValueError("a ViewSpill with a disk limit needs rebuild for the views past it")
        self._codec = codec
        self._budget = int(budget_bytes)
        self._disk = disk_bytes
        self._rebuild = rebuild
        self._absent: set[int] = set()
        self._parent = None if folder is None else Path(folder)
        self._folder: Path | None = None
        self._resident: dict[int, T] = {}
        self._meta: list[Meta] = []
        self._keys: list[tuple[str, ...]] = []
        self.resident_bytes = 0
        self.spilled_bytes = 0
        self._finalizer: weakref.finalize | None = None

    def append(self, value: T) -> None:
        """Add the next view: resident while the budget allows, else written to disk."""
        arrays, meta = self._codec.encode(value)
        size = _nbytes(arrays)
        index = len(self._meta)
        if self.resident_bytes + size <= self._budget:
            self._resident[index] = value
            self.resident_bytes += size
        elif self._disk is not None and self.spilled_bytes + size > self._disk:
            self._absent.add(index)  # rebuilt at each use
        else:
            folder = self._spill_folder()
            for name, array in arrays.items():
                np.save(folder / f"{index}.{name}.npy", np.ascontiguousarray(array))
            self.spilled_bytes += size
        self._meta.append(meta)
        self._keys.append(tuple(arrays))

    def _spill_folder(self) -> Path:
        if self._folder is None:
            parent = self._parent
            if parent is not None:
                parent.mkdir(parents=True, exist_ok=True)
            self._folder = Path(tempfile.mkdtemp(prefix="causalsplat-views-", dir=parent))
            self._finalizer = weakref.finalize(self, shutil.rmtree, self._folder, True)
        return self._folder

    @property
    def n_spilled(self) -> int:
        """Views on disk."""
        return len(self._meta) - len(self._resident) - len(self._absent)

    @property
    def n_rebuilt(self) -> int:
        """Views past the disk limit, rebuilt at each use."""
        return len(self._absent)

    def __len__(self) -> int:
        return len(self._meta)

    def _view(self, index: int) -> T:
        hit = self._resident.get(index)
        if hit is not None:
            return hit
        if index in self._absent:
            assert self._rebuild is not None
            return self._rebuild(index)
        assert self._folder is not None
        arrays = {
            name: np.load(self._folder / f"{index}.{name}.npy", mmap_mode="r")
            for name in self._keys[index]
        }
        return self._codec.decode(arrays, self._meta[index])

    def close(self) -> None:
        """Remove the spilled files now (the resident views stay readable)."""
        if self._finalizer is not None:
            self._finalizer()


class RecomputedWeights(PerView[Contributors]):
    """The blending weights of each view, rebuilt by the rasterizer at each use and never
    kept: memory for one view at a time and no disk, at the price of one rasterization per
    use (the alternative to a :class:`ViewSpill` of the weights)."""

    def __init__(
        self, scene: GaussianScene, cameras: Sequence[Camera], raster: RasterConfig
    ) -> None:
        self._scene = scene
        self._cameras = tuple(cameras)
        self._raster = raster

    def __len__(self) -> int:
        return len(self._cameras)

    def _view(self, index: int) -> Contributors:
        from causalsplat.render import build_contributors

        camera = self._cameras[index]
        return build_contributors(self._scene, camera, config=self._raster, cache=False)
