"""INRIA 3D Gaussian Splatting PLY files: read, write, and extra per-Gaussian properties.

Layout (one ``vertex`` element, one row per Gaussian, float32 unless noted):
``x y z`` (mean), optional ``nx ny nz`` (unused normals), ``f_dc_0..2`` (SH DC per RGB
channel), ``f_rest_0..M-1`` with M = 3 * ((degree+1)**2 - 1) in {0, 9, 24, 45},
``opacity`` (logit), ``scale_0..2`` (log std-dev), ``rot_0..3`` (quaternion w, x, y, z, any
norm). ``f_rest`` is channel-major as INRIA writes it: ``f_rest_{c*(K-1) + j}`` is SH
coefficient ``j+1`` of colour channel ``c``. Any other vertex property (normals,
``entity_id``...) is kept in :attr:`GaussianPly.extra`.

Values are stored raw in :class:`GaussianScene` (activations are its properties), and the
property order, dtypes and header of a file read here are kept in a :class:`PlyLayout`, so
reading and writing back an unchanged float32 file reproduces it byte for byte. plyfile is
imported when a function here is called (``pip install 'causalsplat[build]'``).
"""

from __future__ import annotations

import os
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from causalsplat._atomic import atomic_target
from causalsplat.errors import MissingDependencyError
from causalsplat.io.errors import InvalidSceneError, PlyFormatError
from causalsplat.io.types import GaussianScene

_CORE = ("x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2", "opacity",
         "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3")  # fmt: skip
_REST = re.compile(r"f_rest_(\d+)$")
_PLY_INT_TYPES = (np.int8, np.uint8, np.int16, np.uint16, np.int32, np.uint32)


@dataclass(frozen=True, slots=True)
class PlyLayout:
    """How a PLY file was laid out, so that it can be written back identically.

    Attributes:
        properties: ``(name, numpy dtype string)`` of the vertex properties, in file order.
        text: True for ASCII PLY.
        byte_order: ``'<'``, ``'>'`` or ``'='`` (plyfile's convention).
        comments: header ``comment`` lines; obj_info: header ``obj_info`` lines.
    """

    properties: tuple[tuple[str, str], ...]
    text: bool = False
    byte_order: str = "<"
    comments: tuple[str, ...] = ()
    obj_info: tuple[str, ...] = ()


@dataclass(frozen=True, slots=True, eq=False)
class GaussianPly:
    """A 3DGS PLY as read: the scene, the other per-Gaussian properties, and the layout.

    Attributes:
        scene: the Gaussians (raw parameters, float32).
        extra: property name -> (N,) array (dtype as stored) for every vertex property that
            is not part of the 3DGS parameters, e.g. ``nx``, ``ny``, ``nz``, ``entity_id``.
        layout: the file's property order, dtypes and header lines.
    """

    scene: GaussianScene
    extra: Mapping[str, np.ndarray]
    layout: PlyLayout


def _plyfile() -> Any:
    try:
        import plyfile
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise MissingDependencyError(
            "reading/writing PLY needs plyfile: pip install 'causalsplat[build]'"
        ) from exc
    return plyfile


def default_layout(sh_degree: int, extra: Mapping[str, np.ndarray] | None = None) -> PlyLayout:
    """The INRIA property order (with zero normals) for ``sh_degree``, then ``extra``."""
    n_rest = 3 * ((sh_degree + 1) ** 2 - 1)
    names = ["x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"]
    names += [f"f_rest_{i}" for i in range(n_rest)]
    names += ["opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"]
    props = [(name, "<f4") for name in names]
    for name, arr in (extra or {}).items():
        if name not in names:
            props.append((name, _ply_dtype(name, np.asarray(arr))))
    return PlyLayout(properties=tuple(props))


def _ply_dtype(name: str, arr: np.ndarray) -> str:
    if arr.dtype == np.bool_:
        return "u1"
    if np.issubdtype(arr.dtype, np.integer):
        if arr.dtype.type in _PLY_INT_TYPES:
            return arr.dtype.newbyteorder("<").str
        for t in (np.int32, np.uint32):
            info = np.iinfo(t)
            if arr.size == 0 or (arr.min() >= info.min and arr.max() <= info.max):
                return np.dtype(t).newbyteorder("<").str
        raise PlyFormatError(f"extra property {name!r}: values do not fit a 32-bit PLY integer")
    if np.issubdtype(arr.dtype, np.floating):
        return "<f8" if arr.dtype == np.float64 else "<f4"
    raise PlyFormatError(f"extra property {name!r}: unsupported dtype {arr.dtype}")


def _parse(path: Path) -> Any:
    plyfile = _plyfile()
    try:
        _check_declared_size(path)
    except FileNotFoundError as exc:
        raise PlyFormatError(f"{path}: no such file") from exc
    try:
        # Memory-mapped (copy on write): plyfile then reads a binary element with one
        # structured view of the file, where mmap=False parses it vertex by vertex
        # (25 us a Gaussian). Every column is copied out before the map is dropped.
        with open(path, "rb") as fh:
            return plyfile.PlyData.read(fh, mmap="c")
    except FileNotFoundError as exc:
        raise PlyFormatError(f"{path}: no such file") from exc
    except MemoryError as exc:
        raise PlyFormatError(f"{path}: not enough memory to read the file") from exc
    except (plyfile.PlyParseError, ValueError, EOFError, IndexError, KeyError) as exc:
        raise PlyFormatError(f"{path}: not a readable PLY (truncated or corrupt): {exc}") from exc


_PLY_TYPE_BYTES = {
    "char": 1, "uchar": 1, "int8": 1, "uint8": 1,
    "short": 2, "ushort": 2, "int16": 2, "uint16": 2,
    "int": 4, "uint": 4, "float": 4, "int32": 4, "uint32": 4, "float32": 4,
    "double": 8, "float64": 8,
}  # fmt: skip
#: Longest header read before the file is called not a PLY.
_MAX_HEADER_BYTES = 1 << 20


def _check_declared_size(path: Path) -> None:
    """Refuse a header whose element counts need more bytes than the file holds, before
    anything is allocated for them (a corrupt count would otherwise ask for terabytes), and
    a binary file of fixed-size rows holding more than its header declares (a wrong count,
    or two files joined: the rest would be silently ignored)."""
    with open(path, "rb") as fh:
        head = fh.read(_MAX_HEADER_BYTES)
        size = os.fstat(fh.fileno()).st_size
    end = head.find(b"end_header")
    if not head.startswith(b"ply") or end < 0:
        return  # plyfile names what is wrong
    body = size - (head.find(b"\n", end) + 1)
    binary, needed, count, lists = True, 0, 0, False
    for line in head[:end].decode("ascii", "replace").splitlines():
        words = line.split()
        if words[:1] == ["format"] and len(words) > 1:
            binary = words[1] != "ascii"
        elif words[:1] == ["element"] and len(words) == 3 and words[2].isdigit():
            count = int(words[2])
            needed += count if not binary else 0  # ascii: at least one byte per row
        elif words[:1] == ["property"] and len(words) >= 3 and binary:
            lists = lists or words[1] == "list"
            width = 1 if words[1] == "list" else _PLY_TYPE_BYTES.get(words[1], 1)
            needed += count * width
    if needed > body:
        raise PlyFormatError(
            f"{path}: the header declares {needed:,} bytes of elements but the file holds"
            f" {max(body, 0):,} after it (a corrupt element count, or a truncated file)"
        )
    if binary and not lists and body > needed:
        raise PlyFormatError(
            f"{path}: {body - needed:,} bytes follow the {needed:,} bytes of elements the"
            " header declares (a wrong element count, or data appended to the file)"
        )


def _column(path: Path, data: np.ndarray, name: str) -> np.ndarray:
    if name not in (data.dtype.names or ()):
        raise PlyFormatError(f"{path}: vertex property {name!r} is missing")
    col = np.asarray(data[name], dtype=np.float64)
    bad = ~np.isfinite(col)
    if bad.any():
        raise PlyFormatError(
            f"{path}: vertex property {name!r} has {int(bad.sum())} NaN/Inf value(s), "
            f"first at vertex {int(np.argmax(bad))}"
        )
    return col.astype(np.float32)


def _rest_count(path: Path, names: tuple[str, ...]) -> int:
    idx = sorted(int(m.group(1)) for n in names if (m := _REST.match(n)))
    if idx != list(range(len(idx))):
        raise PlyFormatError(f"{path}: f_rest_* properties are not numbered 0..{len(idx) - 1}")
    if len(idx) not in (0, 9, 24, 45):
        raise PlyFormatError(
            f"{path}: {len(idx)} f_rest_* properties; SH degree 0-3 needs 0, 9, 24 or 45"
        )
    return len(idx)


def read_gaussian_ply(path: str | os.PathLike[str]) -> GaussianPly:
    """Read a 3DGS PLY with its extra properties and layout (see the module docstring).

    Raises :class:`PlyFormatError` (naming the file and property) for an unreadable or
    truncated file, a missing ``vertex`` element or property, NaN/Inf values, an SH count
    that is no degree 0-3, or an all-zero quaternion.
    """
    path = Path(path)
    ply = _parse(path)
    if "vertex" not in [el.name for el in ply.elements]:
        raise PlyFormatError(f"{path}: no 'vertex' element")
    data = ply["vertex"].data
    names = tuple(data.dtype.names or ())
    cols = {name: _column(path, data, name) for name in _CORE}
    n_rest = _rest_count(path, names)
    k = n_rest // 3 + 1
    sh = np.empty((data.shape[0], k, 3), dtype=np.float32)
    for c in range(3):
        sh[:, 0, c] = cols[f"f_dc_{c}"]
        for j in range(k - 1):
            sh[:, j + 1, c] = _column(path, data, f"f_rest_{c * (k - 1) + j}")
    quats = np.stack([cols[f"rot_{i}"] for i in range(4)], axis=1)
    try:
        scene = GaussianScene(
            means=np.stack([cols["x"], cols["y"], cols["z"]], axis=1),
            quats=quats,
            log_scales=np.stack([cols[f"scale_{i}"] for i in range(3)], axis=1),
            opacity_logits=cols["opacity"],
            sh=sh,
        )
    except InvalidSceneError as exc:
        raise PlyFormatError(f"{path}: rot_0..rot_3: {exc}") from exc
    used = set(_CORE) | {f"f_rest_{i}" for i in range(n_rest)}
    extra = {n: np.array(data[n]) for n in names if n not in used}
    layout = PlyLayout(
        properties=tuple((n, data.dtype[n].str) for n in names),
        text=bool(ply.text),
        byte_order=str(ply.byte_order),
        comments=tuple(ply.comments),
        obj_info=tuple(ply.obj_info),
    )
    return GaussianPly(scene=scene, extra=extra, layout=layout)


def read_ply(path: str | os.PathLike[str]) -> GaussianScene:
    """Read the Gaussians of a 3DGS PLY (see :func:`read_gaussian_ply`)."""
    return read_gaussian_ply(path).scene


def _values(scene: GaussianScene, extra: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    k = scene.sh.shape[1]
    vals: dict[str, np.ndarray] = {}
    for i, axis in enumerate("xyz"):
        vals[axis] = scene.means[:, i]
    for c in range(3):
        vals[f"f_dc_{c}"] = scene.sh[:, 0, c]
        for j in range(k - 1):
            vals[f"f_rest_{c * (k - 1) + j}"] = scene.sh[:, j + 1, c]
    vals["opacity"] = scene.opacity_logits
    for i in range(3):
        vals[f"scale_{i}"] = scene.log_scales[:, i]
    for i in range(4):
        vals[f"rot_{i}"] = scene.quats[:, i]
    for name, arr in extra.items():
        arr = np.asarray(arr)
        if arr.shape != (scene.n,):
            raise PlyFormatError(f"extra property {name!r}: shape {arr.shape}, want ({scene.n},)")
        vals[name] = arr
    for name in ("nx", "ny", "nz"):
        vals.setdefault(name, np.zeros(scene.n, dtype=np.float32))
    return vals


def write_ply(
    path: str | os.PathLike[str],
    scene: GaussianScene,
    *,
    extra: Mapping[str, np.ndarray] | None = None,
    layout: PlyLayout | None = None,
    comments: Sequence[str] = (),
) -> None:
    """Write ``scene`` as a 3DGS PLY, with ``extra`` per-Gaussian properties appended
    and ``comments`` added to the header's comment lines.

    ``layout`` (from :func:`read_gaussian_ply`) keeps another file's property order,
    dtypes and header; without it the INRIA order is used (zero normals). Extra integer
    arrays are stored as the smallest 32-bit PLY integer type that holds them (an int64
    ``entity_id`` becomes ``int``). The file is written to a temporary name and renamed,
    so a failure leaves no half-written file.
    """
    path = Path(path)
    extra = dict(extra or {})
    vals = _values(scene, extra)
    base = layout or default_layout(scene.sh_degree)
    props = list(base.properties)
    names = {n for n, _ in props}
    props += [p for p in default_layout(scene.sh_degree, extra).properties if p[0] not in names]
    missing = [n for n, _ in props if n not in vals]
    if missing:
        raise PlyFormatError(f"{path}: no values for layout propert(ies) {missing}")
    n_rest = sum(1 for n, _ in props if _REST.match(n))
    if n_rest != 3 * (scene.sh.shape[1] - 1):
        raise PlyFormatError(
            f"{path}: layout has {n_rest} f_rest_* but the scene's SH needs "
            f"{3 * (scene.sh.shape[1] - 1)}"
        )
    table = np.empty(scene.n, dtype=[(n, t) for n, t in props])
    for n, _ in props:
        table[n] = vals[n]
    plyfile = _plyfile()
    element = plyfile.PlyElement.describe(table, "vertex")
    ply = plyfile.PlyData(
        [element],
        text=base.text,
        byte_order=base.byte_order,
        comments=[*base.comments, *comments],
        obj_info=list(base.obj_info),
    )
    with atomic_target(path) as tmp:
        ply.write(str(tmp))
