"""The rasterizer's hand-off type: :class:`Contributors` (numpy / scipy only)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp


@dataclass(frozen=True, slots=True, eq=False, weakref_slot=True)
class Contributors:
    """Per-view sparse blending weights: pixel x Gaussian, in CSR form.

    Row ``p = row * width + col`` lists the Gaussians that contribute to pixel ``p``, nearest
    first, with weight ``w = alpha * T`` (alpha of the Gaussian at the pixel centre times the
    transmittance in front of it). Rendering any per-Gaussian quantity ``f`` (N, C) is then
    ``W @ f``; with a black background that is the alpha-composited image.

    Attributes:
        width, height: image size in pixels.
        n_gaussians: N, the number of Gaussians of the scene (columns of W).
        indptr: (H*W + 1,) int64 CSR row pointers.
        indices: (nnz,) int32 Gaussian index of each entry, front to back within a row.
        weights: (nnz,) float32 blending weights, in [0, 1], summing to <= 1 per row.
        depths: (N,) float32 camera-frame z of each Gaussian centre (scene units), 0 for
            Gaussians culled from this view.
        key: hex content hash of (scene geometry, camera, config) that built it; empty
            when it was built outside the cache (``build_contributors(cache=False)``).
    """

    width: int
    height: int
    n_gaussians: int
    indptr: np.ndarray
    indices: np.ndarray
    weights: np.ndarray
    depths: np.ndarray
    key: str

    @property
    def n_pixels(self) -> int:
        return self.width * self.height

    @property
    def nnz(self) -> int:
        """Number of stored (pixel, Gaussian) weights."""
        return int(self.weights.shape[0])

    @property
    def nbytes(self) -> int:
        """Memory held by the arrays, in bytes."""
        return int(
            self.indptr.nbytes + self.indices.nbytes + self.weights.nbytes + self.depths.nbytes
        )

    def matrix(self, dtype: npt.DTypeLike = np.float32) -> sp.csr_matrix:
        """W as a scipy CSR matrix of shape (H*W, N).

        float32 shares the arrays; another ``dtype`` copies only the weights. Rows keep
        their front-to-back order: use this rather than ``matrix().astype(...)``, which
        scipy follows with a sort of every row by column (the rows are not in column
        order), a pass over all entries each time.
        """
        dtype = np.dtype(dtype)
        data = self.weights if dtype == self.weights.dtype else self.weights.astype(dtype)
        return sp.csr_matrix(
            (data, self.indices, self.indptr), shape=(self.n_pixels, self.n_gaussians)
        )

    def rows(self, pixels: np.ndarray) -> Contributors:
        """The weights of the flat ``pixels`` only, in that order, as a 1-row "image".

        The result has ``width = len(pixels)`` and ``height = 1``; rendering it gives the
        rows of the full render at ``pixels``. Copies only the selected weights.

        >>> c = Contributors(2, 2, 3, np.array([0, 1, 1, 3, 4]), np.array([0, 1, 2, 2], np.int32),
        ...                  np.array([.5, .25, .5, 1.], np.float32), np.zeros(3, np.float32), "")
        >>> r = c.rows(np.array([3, 2]))
        >>> r.indptr.tolist(), r.indices.tolist(), r.weights.tolist()
        ([0, 1, 3], [2, 1, 2], [1.0, 0.25, 0.5])
        """
        pixels = self._checked(pixels)
        starts = np.asarray(self.indptr)[pixels]
        lengths = np.asarray(self.indptr)[pixels + 1] - starts
        indptr = np.zeros(pixels.shape[0] + 1, dtype=np.int64)
        np.cumsum(lengths, out=indptr[1:])
        take = np.repeat(starts - indptr[:-1], lengths) + np.arange(indptr[-1])
        indices = np.asarray(self.indices)[take]
        weights = np.asarray(self.weights)[take]
        return Contributors(
            int(pixels.shape[0]), 1, self.n_gaussians, indptr, indices, weights, self.depths,
            self.key,
        )  # fmt: skip

    def composite_rows(self, pixels: np.ndarray, values: np.ndarray) -> np.ndarray:
        """(P, C) ``W[pixels] @ values`` for (N, C) ``values``, in their dtype: the render at
        the flat ``pixels`` only, reading their weights in place where numba imports."""
        pixels = self._checked(pixels)
        values = np.ascontiguousarray(values)
        from causalsplat.render._backend import numba_available

        if not numba_available():
            return np.asarray(self.rows(pixels).matrix(values.dtype) @ values)
        from causalsplat.render._kernel_rows import rows_product

        out = np.zeros((pixels.shape[0], values.shape[1]), dtype=values.dtype)
        rows_product(self.indptr, self.indices, self.weights, pixels, values, out)
        return out

    def transposed_rows(
        self, pixels: np.ndarray, grad: np.ndarray, out: np.ndarray | None = None
    ) -> np.ndarray:
        """(N, C) ``W[pixels]^T @ grad`` for (P, C) ``grad``: the gradient of
        :meth:`composite_rows` with respect to the values.

        ``out``: a C-contiguous (N, C) array of ``grad``'s dtype to write the result into
        (overwritten; the training reuses one, sparing a fresh array each step)."""
        pixels = self._checked(pixels)
        grad = np.ascontiguousarray(grad)
        shape = (self.n_gaussians, grad.shape[1])
        if out is not None and (
            out.shape != shape or out.dtype != grad.dtype or not out.flags.c_contiguous
        ):
            from causalsplat.render.errors import RenderError

            raise RenderError(f"out must be a C-contiguous {grad.dtype} array of shape {shape}")
        from causalsplat.render._backend import numba_available

        if not numba_available():
            result = np.asarray(self.rows(pixels).matrix(grad.dtype).T @ grad)
            if out is None:
                return result
            out[...] = result
            return out
        from causalsplat.render._kernel_rows import rows_transposed_product

        if out is None:
            out = np.zeros(shape, dtype=grad.dtype)
        else:
            out.fill(0)
        rows_transposed_product(self.indptr, self.indices, self.weights, pixels, grad, out)
        return out

    def _checked(self, pixels: np.ndarray) -> np.ndarray:
        pixels = np.asarray(pixels, dtype=np.int64)
        if pixels.ndim != 1 or (
            pixels.size and (pixels.min() < 0 or pixels.max() >= self.n_pixels)
        ):
            from causalsplat.render.errors import RenderError

            raise RenderError(f"pixels must be a 1-D array of flat indices in [0, {self.n_pixels})")
        return pixels

    def alpha(self) -> np.ndarray:
        """(H, W) float64 accumulated opacity: the sum of the weights of each pixel."""
        # Summed in float64 straight from the float32 weights (no float64 copy of them),
        # each row in its stored order, compiled or by numpy.
        from causalsplat.render._backend import numba_available

        out = np.zeros(self.n_pixels, dtype=np.float64)
        if numba_available():
            from causalsplat.render._kernel_rows import row_sums

            row_sums(self.indptr, self.weights, out)
            return out.reshape(self.height, self.width)
        starts = np.asarray(self.indptr[:-1])
        rows = np.flatnonzero(np.diff(self.indptr) > 0)
        if rows.size:
            out[rows] = np.add.reduceat(self.weights, starts[rows], dtype=np.float64)
        return out.reshape(self.height, self.width)

    def composite(self, values: np.ndarray) -> np.ndarray:
        """Composite per-Gaussian ``values`` (N,) or (N, C) into (H, W) or (H, W, C) float64."""
        v = np.asarray(values, dtype=np.float64)
        out = self.matrix(np.float64) @ v
        return np.asarray(out).reshape((self.height, self.width, *v.shape[1:]))
