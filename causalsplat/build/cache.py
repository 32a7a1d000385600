"""A content-addressed cache of pipeline stages on disk.

A stage's result is stored as ``<dir>/<stage>/<key>.npz`` where ``key`` is the SHA-256 of
everything the result depends on (input file hashes, the options of this stage and of
every stage before it). A changed later stage never invalidates an earlier one; a changed
input or earlier option gives a new key. Files are written atomically (a temporary file
renamed into place); an unreadable cache file is ignored and recomputed, never trusted.
The directory defaults to ``$CAUSALSPLAT_CACHE`` or ``~/.cache/causalsplat``.
"""

from __future__ import annotations

import hashlib
import json
import os
import zipfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import scipy.sparse as sp

from causalsplat.masks.files import write_npz


def default_cache_dir() -> Path:
    env = os.environ.get("CAUSALSPLAT_CACHE")
    return Path(env) if env else Path.home() / ".cache" / "causalsplat"


def cache_key(*parts: Any) -> str:
    """SHA-256 hex of the canonical JSON of ``parts``."""
    text = json.dumps(parts, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()


class StageCache:
    """Read and write stage results (dicts of arrays) under a directory; ``None`` disables."""

    def __init__(self, directory: str | Path | None) -> None:
        self.directory = None if directory is None else Path(directory)

    def _path(self, stage: str, key: str) -> Path | None:
        return None if self.directory is None else self.directory / stage / f"{key}.npz"

    def get(self, stage: str, key: str) -> dict[str, np.ndarray] | None:
        path = self._path(stage, key)
        if path is None or not path.is_file():
            return None
        try:
            with np.load(path, allow_pickle=False) as data:
                return {name: data[name] for name in data.files}
        except (OSError, ValueError, EOFError, zipfile.BadZipFile):
            return None

    def put(self, stage: str, key: str, arrays: Mapping[str, np.ndarray]) -> None:
        path = self._path(stage, key)
        if path is None:
            return
        path.parent.mkdir(parents=True, exist_ok=True)
        write_npz(path, arrays, compress=False)


def pack_csr(prefix: str, matrix: sp.csr_matrix) -> dict[str, np.ndarray]:
    """A CSR matrix as named arrays (see :func:`unpack_csr`)."""
    m = matrix.tocsr()
    return {
        f"{prefix}_data": m.data,
        f"{prefix}_indices": m.indices,
        f"{prefix}_indptr": m.indptr,
        f"{prefix}_shape": np.asarray(m.shape, dtype=np.int64),
    }


def unpack_csr(prefix: str, arrays: Mapping[str, np.ndarray]) -> sp.csr_matrix:
    shape = tuple(int(v) for v in arrays[f"{prefix}_shape"])
    return sp.csr_matrix(
        (arrays[f"{prefix}_data"], arrays[f"{prefix}_indices"], arrays[f"{prefix}_indptr"]),
        shape=shape,
    )
