"""The Gaussians of a stored scene as one compact binary payload for the viewer page.

The store keeps the graph and the entity of every Gaussian, not the Gaussians: they are
read from the scene folder's 3DGS PLY (see :mod:`causalsplat.export`), whose SHA-256 is
checked against the one recorded at build time. numpy only (the PLY reader needs plyfile,
from the ``field`` extra); a scene that has no Gaussians to show (ingested objects, a
moved folder, an edited PLY, no plyfile) gets a payload of zero Gaussians whose header
says why, so the page can still draw its entities as boxes.

Payload layout (little-endian; every offset a multiple of 4)::

    bytes 0..3    b"CSPL"
    bytes 4..7    uint32 format version (1)
    bytes 8..11   uint32 H, the length of the JSON header (UTF-8, space-padded to 4)
    bytes 12..    the JSON header, then the arrays, each ``count`` rows, in this order:
      position  float32 x3   Gaussian centre, world frame, scene units
      scale     float32 x3   per-axis standard deviation, scene units
      rotation  int8 x4      unit quaternion wxyz, times 127, rounded
      color     uint8 x4     RGB of the SH DC term and the opacity, times 255, rounded
      entity    int32 x1     the Gaussian's entity id (-1: none)

The header holds ``scene_id``, ``count`` (Gaussians in the payload), ``total`` (in the
PLY), ``sampling``, ``reason`` (why there are no Gaussians, else null), ``palette``
(entity id, as text -> ``"#rrggbb"``, the colour the page draws each entity in) and
``arrays`` (name, dtype, components, byte offset from the start of the array section).

When the PLY has more Gaussians than ``max_splats``, the payload keeps the ``max_splats``
that cover the most of the picture: the largest ``opacity * s1 * s2`` (``s1, s2`` the two
largest standard deviations, i.e. the opacity times the area of the widest cross-section),
ties broken by file order, and keeps them in file order. The choice is deterministic.
"""

from __future__ import annotations

import colorsys
import hashlib
import json
import struct
import threading
from collections import OrderedDict
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from causalsplat.colors import rgb_to_hex
from causalsplat.errors import CausalSplatError
from causalsplat.serve.app import App, HttpError, Request, Response
from graph_store import SceneGraph

MAGIC = b"CSPL"
FORMAT_VERSION = 1
#: Gaussians sent when the request does not say (about 7 MB).
DEFAULT_MAX_SPLATS = 200_000
#: The most Gaussians one request may ask for.
MAX_SPLATS_LIMIT = 5_000_000
#: Bytes per Gaussian in the payload.
BYTES_PER_SPLAT = 36
#: The colour of an answer's entities on the page; no entity colour is near it.
HIGHLIGHT_COLOR = "#ff00ff"

_ARRAYS = (
    ("position", "<f4", 3),
    ("scale", "<f4", 3),
    ("rotation", "i1", 4),
    ("color", "u1", 4),
    ("entity", "<i4", 1),
)


class SplatRequestError(CausalSplatError, ValueError):
    """A request for a scene's Gaussians is malformed (the message names the value)."""


@dataclass(frozen=True, slots=True)
class SplatArrays:
    """The Gaussians the page gets, activated and subsampled.

    Attributes:
        position: (M, 3) float32, centres, world frame, scene units.
        scale: (M, 3) float32, per-axis standard deviation, scene units.
        rotation: (M, 4) int8, unit quaternions wxyz times 127.
        color: (M, 4) uint8, RGB of the SH DC term and the opacity, times 255.
        entity: (M,) int32, entity id per Gaussian, -1 for none.
        total: how many Gaussians the PLY holds (M <= total).
    """

    position: np.ndarray
    scale: np.ndarray
    rotation: np.ndarray
    color: np.ndarray
    entity: np.ndarray
    total: int

    @property
    def count(self) -> int:
        return int(self.position.shape[0])


def parse_max_splats(value: str | None) -> int:
    """The ``max`` query parameter as a count (``None``: the default).

    >>> parse_max_splats(None) == DEFAULT_MAX_SPLATS
    True
    >>> parse_max_splats("5000")
    5000
    >>> parse_max_splats("0")
    Traceback (most recent call last):
        ...
    causalsplat.serve.splats.SplatRequestError: max must be an integer from 1 to 5000000, got '0'
    """
    if value is None:
        return DEFAULT_MAX_SPLATS
    text = value.strip()
    if not text.isdigit() or not 1 <= int(text) <= MAX_SPLATS_LIMIT:
        raise SplatRequestError(
            f"max must be an integer from 1 to {MAX_SPLATS_LIMIT}, got {value!r}"
        )
    return int(text)


def entity_palette(entity_ids: Iterable[int]) -> dict[int, str]:
    """A display colour per entity id, ``"#rrggbb"``, the same for an id in every scene.

    Hues step by the golden angle so that neighbouring ids differ; they stay below 288
    degrees, away from the magenta of :data:`HIGHLIGHT_COLOR`.

    >>> entity_palette([0, 1])
    {0: '#f2945a', 1: '#3fb3f2'}
    """
    out = {}
    for i in entity_ids:
        hue = ((0.08 + 0.618033988749895 * i) % 1.0) * 0.8
        sat = (0.63, 0.74, 0.52)[i % 3]
        val = (0.95, 0.9, 0.82)[(i // 3) % 3]
        r, g, b = colorsys.hsv_to_rgb(hue, sat, val)
        out[i] = rgb_to_hex((r, g, b))
    return out


def select_splats(opacity: np.ndarray, scales: np.ndarray, max_splats: int) -> np.ndarray:
    """Indices (ascending) of the ``max_splats`` Gaussians that cover the most area.

    The weight is ``opacity * s1 * s2`` with ``s1 >= s2`` the two largest of the three
    standard deviations; ties go to the earlier Gaussian. All indices when there are no
    more than ``max_splats``.

    >>> select_splats(np.array([0.9, 0.1, 0.9]), np.ones((3, 3)), 2).tolist()
    [0, 2]
    """
    n = int(opacity.shape[0])
    if n <= max_splats:
        return np.arange(n, dtype=np.int64)
    two = np.sort(scales, axis=1)[:, 1:]
    weight = opacity.astype(np.float64) * two[:, 0] * two[:, 1]
    order = np.argsort(-weight, kind="stable")[:max_splats]
    return np.sort(order)


def activate_splats(
    means: np.ndarray,
    quats_wxyz: np.ndarray,
    scales: np.ndarray,
    opacity: np.ndarray,
    rgb: np.ndarray,
    labels: np.ndarray | None,
    max_splats: int,
) -> SplatArrays:
    """Subsample (see :func:`select_splats`) and quantise activated Gaussians.

    Args:
        means: (N, 3) centres; quats_wxyz: (N, 4) unit quaternions; scales: (N, 3)
            standard deviations; opacity: (N,) in [0, 1]; rgb: (N, 3) in [0, 1].
        labels: (N,) entity id per Gaussian, or None (every Gaussian gets -1).
        max_splats: the most Gaussians to keep.
    """
    index = select_splats(opacity, scales, max_splats)
    entity = (
        np.full(index.shape[0], -1, dtype=np.int32)
        if labels is None
        else np.asarray(labels)[index].astype(np.int32)
    )
    color = np.empty((index.shape[0], 4), dtype=np.uint8)
    color[:, :3] = np.rint(np.clip(rgb[index], 0.0, 1.0) * 255.0)
    color[:, 3] = np.rint(np.clip(opacity[index], 0.0, 1.0) * 255.0)
    return SplatArrays(
        position=np.ascontiguousarray(means[index], dtype=np.float32),
        scale=np.ascontiguousarray(scales[index], dtype=np.float32),
        rotation=np.rint(np.clip(quats_wxyz[index], -1.0, 1.0) * 127.0).astype(np.int8),
        color=color,
        entity=entity,
        total=int(opacity.shape[0]),
    )


def encode_payload(
    graph: SceneGraph, splats: SplatArrays | None, *, reason: str | None = None
) -> bytes:
    """The binary payload (layout in the module docstring); ``splats=None``: no Gaussians."""
    count = 0 if splats is None else splats.count
    arrays, offset = [], 0
    for name, dtype, comps in _ARRAYS:
        arrays.append({"name": name, "dtype": dtype, "components": comps, "offset": offset})
        offset += count * comps * np.dtype(dtype).itemsize
    header = {
        "scene_id": graph.scene_id,
        "count": count,
        "total": 0 if splats is None else splats.total,
        "sampling": "all" if splats is None or count == splats.total else "largest",
        "reason": reason,
        "palette": {str(k): v for k, v in entity_palette(e.id for e in graph.entities).items()},
        "highlight": HIGHLIGHT_COLOR,
        "arrays": arrays,
    }
    text = json.dumps(header, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    parts = [MAGIC, struct.pack("<II", FORMAT_VERSION, len(text)), text]
    if splats is not None:
        for name, dtype, _ in _ARRAYS:
            parts.append(np.ascontiguousarray(getattr(splats, name), dtype=dtype).tobytes())
    return b"".join(parts)


def decode_payload(data: bytes) -> tuple[dict[str, object], dict[str, np.ndarray]]:
    """The header and the arrays of a payload (the reverse of :func:`encode_payload`)."""
    if data[:4] != MAGIC:
        raise SplatRequestError("not a splat payload (no CSPL magic)")
    version, size = struct.unpack_from("<II", data, 4)
    if version != FORMAT_VERSION:
        raise SplatRequestError(f"splat payload version {version}, expected {FORMAT_VERSION}")
    header = json.loads(data[12 : 12 + size])
    base = 12 + size
    count = int(header["count"])
    arrays = {}
    for spec in header["arrays"]:
        shape = (count, spec["components"]) if spec["components"] > 1 else (count,)
        arrays[spec["name"]] = np.frombuffer(
            data,
            dtype=spec["dtype"],
            count=count * spec["components"],
            offset=base + spec["offset"],
        ).reshape(shape)
    return header, arrays


def _read_splats(
    graph: SceneGraph, labels: np.ndarray | None, ply_path: Path, max_splats: int
) -> SplatArrays:
    from causalsplat.io import read_gaussian_ply

    scene = read_gaussian_ply(ply_path).scene
    if labels is not None and np.asarray(labels).shape != (scene.n,):
        raise SplatRequestError(
            f"scene {graph.scene_id!r}: {np.asarray(labels).shape[0]} stored labels for a PLY "
            f"of {scene.n} Gaussians"
        )
    return activate_splats(
        scene.means, scene.rotations, scene.scales, scene.opacities, scene.colors,
        labels, max_splats,
    )  # fmt: skip


class SplatCache:
    """Payloads by content: the PLY (path, size, modification time), labels and ``max``.

    A changed PLY misses the cache and is hashed again (and refused if it no longer has the
    recorded SHA-256). Holds at most ``capacity`` payloads; safe to share between threads.
    """

    def __init__(self, capacity: int = 4) -> None:
        self._capacity = capacity
        self._items: OrderedDict[tuple[object, ...], bytes] = OrderedDict()
        self._lock = threading.Lock()

    def payload(self, graph: SceneGraph, labels: np.ndarray | None, *, max_splats: int) -> bytes:
        """The payload of ``graph``'s Gaussians (zero of them, with a reason, when the scene
        has none to show)."""
        from causalsplat.build.folder import find_ply
        from causalsplat.export.source import check_hash, source_folder

        try:
            root = source_folder(graph)
            ply_path = find_ply(root)
            stat = ply_path.stat()
        except (CausalSplatError, OSError) as exc:
            return encode_payload(graph, None, reason=str(exc).splitlines()[0])
        digest = "-" if labels is None else hashlib.sha1(np.asarray(labels).tobytes()).hexdigest()
        ids = tuple(e.id for e in graph.entities)
        key = (graph.scene_id, ids, str(ply_path.resolve()), stat.st_size, stat.st_mtime_ns,
               digest, max_splats)  # fmt: skip
        with self._lock:
            if key in self._items:
                self._items.move_to_end(key)
                return self._items[key]
        try:
            check_hash(graph, root, ply_path)
            payload = encode_payload(graph, _read_splats(graph, labels, ply_path, max_splats))
        except (CausalSplatError, OSError) as exc:
            return encode_payload(graph, None, reason=str(exc).splitlines()[0])
        with self._lock:
            self._items[key] = payload
            while len(self._items) > self._capacity:
                self._items.popitem(last=False)
        return payload


#: The payloads of this process's server(s).
CACHE = SplatCache()


def get_splats(app: App, request: Request, params: dict[str, str]) -> Response:
    """``GET /api/scenes/{scene_id}/splats[?max=N]``: the payload of the scene's Gaussians
    (``application/octet-stream``, layout in the module docstring)."""
    values = request.query.get("max", [])
    try:
        max_splats = parse_max_splats(values[-1] if values else None)
    except SplatRequestError as exc:
        raise HttpError(400, str(exc)) from None
    scene = app.scene(params["scene_id"])
    with app.locked():
        graph = scene.graph
        labels = scene.gaussian_labels()
    data = CACHE.payload(graph, labels, max_splats=max_splats)
    response = Response(200, data, "application/octet-stream")
    response.headers["Cache-Control"] = "no-cache"
    return response
