"""Reading and writing ``masks/<image stem>.npz`` files (DESIGN §9).

A mask file is a NumPy ``.npz`` archive with

- ``masks``: (M, H, W) bool (``uint8`` holding only 0/1 is accepted on reading);
- ``labels`` (optional): (M,) unicode strings, one category name per mask;
- ``scores`` (optional): (M,) float, one confidence per mask;
- ``ids`` (optional, GT masks only): (M,) int, the instance id of each mask.

Files are written deterministically (fixed zip timestamps, sorted keys, no pickles), so the
same masks always give the same bytes, and atomically (a temporary file renamed into place).
"""

from __future__ import annotations

import io
import zipfile
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from causalsplat._atomic import atomic_target
from causalsplat.masks.types import MaskFormatError, MaskSet


def view_files(
    folder: Path, suffixes: tuple[str, ...], *, what: str, each: str, error: type[Exception]
) -> list[Path]:
    """The files of ``folder`` whose suffix is one of ``suffixes``, sorted by name, one per
    view (a file's stem names its view). Raises ``error`` for a folder that is not one, a
    folder without such files (``what``: "mask files") and two ``each`` ("files") of one
    view."""
    if not folder.is_dir():
        raise error(f"{folder}: not a folder of {what}")
    files = sorted(p for p in folder.iterdir() if p.suffix.lower() in suffixes and p.is_file())
    if not files:
        raise error(f"{folder}: no {what} ({', '.join(suffixes)})")
    stems = [p.stem for p in files]
    twice = sorted({s for s in stems if stems.count(s) > 1})
    if twice:
        raise error(f"{folder}: several {each} for view {twice[0]!r}")
    return files


#: Timestamp stored for every member of archives written here (the zip epoch).
_ZIP_EPOCH = (1980, 1, 1, 0, 0, 0)


def write_npz(path: str | Path, arrays: Mapping[str, np.ndarray], *, compress: bool = True) -> None:
    """Write ``arrays`` as an ``.npz`` archive, byte-for-byte reproducible.

    Unlike :func:`numpy.savez`, every member gets the same fixed timestamp, members are
    sorted by name, and object arrays are refused (they would need pickling).
    """
    path = Path(path)
    buffer = io.BytesIO()
    method = zipfile.ZIP_DEFLATED if compress else zipfile.ZIP_STORED
    with zipfile.ZipFile(buffer, "w", compression=method) as archive:
        for name in sorted(arrays):
            arr = np.ascontiguousarray(arrays[name])
            if arr.dtype.hasobject:
                raise MaskFormatError(f"{path}: array {name!r} has dtype object (not storable)")
            member = io.BytesIO()
            np.lib.format.write_array(member, arr, allow_pickle=False)
            info = zipfile.ZipInfo(f"{name}.npy", date_time=_ZIP_EPOCH)
            info.compress_type = method
            info.external_attr = 0o644 << 16
            archive.writestr(info, member.getvalue())
    with atomic_target(path) as tmp:
        tmp.write_bytes(buffer.getvalue())


def write_masks(path: str | Path, maskset: MaskSet) -> None:
    """Write one view's masks to ``path`` (an ``.npz`` file, see the module docstring)."""
    arrays: dict[str, np.ndarray] = {"masks": maskset.masks}
    if maskset.labels is not None:
        width = max([1, *(len(label) for label in maskset.labels)])
        arrays["labels"] = np.array(maskset.labels, dtype=f"<U{width}").reshape(-1)
    if maskset.scores is not None:
        arrays["scores"] = maskset.scores.astype(np.float32)
    if maskset.ids is not None:
        arrays["ids"] = maskset.ids.astype(np.int64)
    write_npz(path, arrays)


def _load_members(path: Path) -> dict[str, np.ndarray]:
    try:
        data = np.load(path, allow_pickle=False)
    except (FileNotFoundError, IsADirectoryError, PermissionError):
        raise
    except (ValueError, OSError, EOFError, zipfile.BadZipFile) as exc:
        raise MaskFormatError(f"{path}: not a readable .npz archive ({exc})") from exc
    if not isinstance(data, np.lib.npyio.NpzFile):
        raise MaskFormatError(f"{path}: a single .npy array, not an .npz archive of masks")
    try:
        with data:
            return {key: data[key] for key in data.files}
    except (ValueError, OSError, EOFError, zipfile.BadZipFile) as exc:
        # e.g. an object array (would need pickling) or a truncated member
        raise MaskFormatError(f"{path}: unreadable member ({exc})") from exc


def _masks_array(path: Path, arr: np.ndarray) -> np.ndarray:
    if arr.ndim != 3:
        raise MaskFormatError(f"{path}: 'masks' has shape {arr.shape}; expected (M, H, W)")
    if arr.dtype == np.bool_:
        return arr
    if arr.dtype == np.uint8 and not np.any(arr > 1):
        return arr.astype(bool)
    raise MaskFormatError(f"{path}: 'masks' has dtype {arr.dtype}; expected bool (M, H, W)")


def _labels(path: Path, raw: np.ndarray, m: int) -> tuple[str, ...]:
    if raw.dtype.kind not in "US" or raw.ndim != 1:
        raise MaskFormatError(
            f"{path}: 'labels' has dtype {raw.dtype}, shape {raw.shape}; expected (M,) str"
        )
    if raw.shape[0] != m:
        raise MaskFormatError(f"{path}: {raw.shape[0]} labels for {m} masks")
    return tuple(
        x.decode("utf-8", "replace") if isinstance(x, bytes) else str(x) for x in raw.tolist()
    )


def read_masks(
    path: str | Path, *, view: str | None = None, image_size: tuple[int, int] | None = None
) -> MaskSet:
    """Read one view's masks.

    Args:
        path: the ``.npz`` file.
        view: the view name to store (default: the file stem).
        image_size: ``(width, height)`` the masks must have, or ``None`` to accept any.

    Raises :class:`MaskFormatError` for a file that is not an npz archive, lacks ``masks``,
    or has a wrong dtype, shape or count; ``FileNotFoundError`` when it does not exist.
    """
    path = Path(path)
    members = _load_members(path)
    if "masks" not in members:
        raise MaskFormatError(f"{path}: no 'masks' array (has: {sorted(members)})")
    masks = _masks_array(path, members["masks"])
    m = masks.shape[0]
    if image_size is not None and (masks.shape[2], masks.shape[1]) != tuple(image_size):
        raise MaskFormatError(
            f"{path}: masks are {masks.shape[2]}x{masks.shape[1]} pixels; expected "
            f"{image_size[0]}x{image_size[1]}"
        )
    labels = _labels(path, members["labels"], m) if "labels" in members else None
    for key in ("scores", "ids"):
        if key in members and members[key].shape != (m,):
            raise MaskFormatError(
                f"{path}: '{key}' has shape {members[key].shape}; expected ({m},) for {m} masks"
            )
    try:
        return MaskSet(
            view=path.stem if view is None else view,
            masks=masks,
            labels=labels,
            scores=members.get("scores"),
            ids=members.get("ids"),
        )
    except MaskFormatError as exc:
        raise MaskFormatError(f"{path}: {exc}") from exc


def read_mask_dir(
    directory: str | Path, *, image_size: tuple[int, int] | None = None
) -> dict[str, MaskSet]:
    """All ``*.npz`` mask files of a folder, keyed by image stem (sorted)."""
    directory = Path(directory)
    if not directory.is_dir():
        raise FileNotFoundError(2, "No such mask folder", str(directory))
    return {p.stem: read_masks(p, image_size=image_size) for p in sorted(directory.glob("*.npz"))}
