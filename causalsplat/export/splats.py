"""A built scene's 3DGS PLY with the entity of every Gaussian: beside it, or in it.

By default the scene folder's PLY is copied byte for byte (after its SHA-256 is checked
against the build's), so every 3DGS viewer that opens the source opens the copy: the
INRIA SIBR viewer and its C++ ports read fixed-size vertex records and refuse a file
with a property they do not know. The labels go to two files beside it,
``<stem>.labels.npy`` (``(N,)`` int32, row ``i`` the entity of vertex ``i``, ``-1``:
none) and ``<stem>.labels.json`` (the scene, the PLY's SHA-256 and size, and per entity
its category and a display colour). ``embed=True`` writes one PLY instead: the source's
header and records, in the source's property order and types, with one ``int``
property ``causalsplat_entity`` appended to each vertex (for tools that read any
property by name). Other properties are kept as they are, including a ground-truth
``entity_id`` written by ``causalsplat synth`` or ``prepare-scannet``.
"""

from __future__ import annotations

import hashlib
import json
import re
import shutil
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from causalsplat.build.folder import find_ply
from causalsplat.export._palette import category_color
from causalsplat.export.source import ExportError, check_hash, source_folder
from causalsplat.io import read_gaussian_ply, write_ply
from graph_store import SceneGraph

#: The vertex property ``embed=True`` appends (not ``entity_id``: that name is the
#: ground truth's in the synthetic and ScanNet scene folders).
EMBEDDED_PROPERTY = "causalsplat_entity"
#: ``format`` of the sidecar JSON.
SIDECAR_FORMAT = "causalsplat-gaussian-labels"


@dataclass(frozen=True, slots=True)
class PlyExport:
    """The files :func:`export_labelled_ply` wrote.

    Attributes:
        ply: the PLY (a copy of the source, or the source with ``causalsplat_entity``).
        labels_npy: ``(N,)`` int32 labels beside the copy; ``None`` when embedded.
        labels_json: what the labels mean; ``None`` when embedded.
        per_entity: one PLY per entity with Gaussians (``per_entity_dir``), in id order.
    """

    ply: Path
    labels_npy: Path | None
    labels_json: Path | None
    per_entity: tuple[Path, ...] = ()

    @property
    def paths(self) -> list[Path]:
        """Every file written, the PLY first."""
        side = [p for p in (self.labels_npy, self.labels_json) if p is not None]
        return [self.ply, *side, *self.per_entity]


def sidecar_paths(out: str | Path) -> tuple[Path, Path]:
    """The ``.labels.npy`` and ``.labels.json`` written beside the PLY ``out``.

    >>> [p.name for p in sidecar_paths("exports/room.ply")]
    ['room.labels.npy', 'room.labels.json']
    """
    out = Path(out)
    stem = out.stem if out.suffix.lower() == ".ply" else out.name
    return out.with_name(f"{stem}.labels.npy"), out.with_name(f"{stem}.labels.json")


def labels_for(graph: SceneGraph, labels: np.ndarray | None, n: int) -> np.ndarray:
    """The stored labels as ``(n,)`` int32, or :class:`ExportError` naming the mismatch."""
    if labels is None:
        raise ExportError(f"scene {graph.scene_id!r} stores no per-Gaussian labels")
    labels = np.asarray(labels)
    if labels.shape != (n,):
        raise ExportError(
            f"scene {graph.scene_id!r}: {labels.shape[0]} stored labels for a PLY of {n} Gaussians"
        )
    return labels.astype(np.int32)


def export_labelled_ply(
    graph: SceneGraph,
    labels: np.ndarray | None,
    out: str | Path,
    *,
    source: str | Path | None = None,
    embed: bool = False,
    per_entity_dir: str | Path | None = None,
) -> PlyExport:
    """Write the scene's 3DGS PLY and the entity of each Gaussian (module docstring).

    Args:
        graph: a built scene's graph (its provenance names the scene folder and the PLY's
            SHA-256).
        labels: the scene's stored labels (:meth:`causalsplat.api.Scene.gaussian_labels`).
        out: the PLY to write; the sidecar files go beside it (:func:`sidecar_paths`).
        source: the scene folder, when not the one recorded at build time.
        embed: append ``causalsplat_entity`` to the PLY instead of writing the sidecar.
        per_entity_dir: also write one PLY per entity there, ``<id>_<category>.ply``, in
            the source's layout.

    Raises :class:`ExportError` when the folder or its PLY is missing or changed, the scene
    stores no labels, or ``out`` is the source PLY itself.
    """
    root = source_folder(graph, source)
    ply_path = find_ply(root)
    check_hash(graph, root, ply_path)
    out = Path(out)
    if out.exists() and out.resolve() == ply_path.resolve():
        raise ExportError(f"{out} is the scene's source PLY: write the export elsewhere")
    if out.is_dir():
        raise ExportError(f"{out} is a folder: give the PLY's file name")
    if embed or per_entity_dir is not None:
        ply = read_gaussian_ply(ply_path)
        ids = labels_for(graph, labels, ply.scene.n)
    else:
        ids = labels_for(graph, labels, vertex_count(ply_path))
    if embed:
        extra = {**ply.extra, EMBEDDED_PROPERTY: ids}
        write_ply(out, ply.scene, extra=extra, layout=ply.layout)
        result = PlyExport(out, None, None)
    else:
        npy, meta = sidecar_paths(out)
        with _atomic(out) as tmp:
            shutil.copyfile(ply_path, tmp)
        with _atomic(npy) as tmp, tmp.open("wb") as fh:
            np.save(fh, ids.astype("<i4"), allow_pickle=False)
        document = sidecar_document(graph, ids, out)
        with _atomic(meta) as tmp:
            tmp.write_text(json.dumps(document, indent=2, ensure_ascii=False) + "\n", "utf-8")
        result = PlyExport(out, npy, meta)
    if per_entity_dir is None:
        return result
    folder = Path(per_entity_dir)
    folder.mkdir(parents=True, exist_ok=True)
    written = []
    for e in sorted(graph.entities, key=lambda e: e.id):
        index = np.flatnonzero(ids == e.id)
        if index.size == 0:
            continue
        name = re.sub(r"[^A-Za-z0-9_.-]+", "_", e.category)
        path = folder / f"{e.id}_{name}.ply"
        sub = {k: np.asarray(v)[index] for k, v in ply.extra.items()}
        write_ply(path, ply.scene.subset(index), extra=sub, layout=ply.layout)
        written.append(path)
    return PlyExport(result.ply, result.labels_npy, result.labels_json, tuple(written))


def sidecar_document(graph: SceneGraph, ids: np.ndarray, ply: Path) -> dict[str, object]:
    """The ``.labels.json`` of :func:`export_labelled_ply` for the PLY file ``ply``."""
    npy, _ = sidecar_paths(ply)
    counts = np.bincount(ids[ids >= 0]) if np.any(ids >= 0) else np.zeros(0, dtype=np.int64)
    entities = {}
    for e in sorted(graph.entities, key=lambda e: e.id):
        entities[str(e.id)] = {
            "category": e.category,
            "external_id": e.external_id,
            "gaussians": int(counts[e.id]) if e.id < counts.size else 0,
            "display_rgb": list(category_color(e.category)),
        }
    return {
        "format": SIDECAR_FORMAT,
        "version": 1,
        "scene_id": graph.scene_id,
        "ply": ply.name,
        "ply_sha256": _sha256(ply),
        "ply_bytes": ply.stat().st_size,
        "labels": npy.name,
        "count": int(ids.size),
        "dtype": "int32",
        "none": -1,
        "meaning": "labels[i] is the stored entity id of PLY vertex i; -1: no entity",
        "entities": entities,
    }


def vertex_count(path: Path) -> int:
    """The ``element vertex`` count of a PLY's header (the body is not read)."""
    with path.open("rb") as fh:
        for _ in range(10_000):
            line = fh.readline()
            if not line or line.strip() == b"end_header":
                break
            words = line.split()
            if words[:2] == [b"element", b"vertex"] and len(words) == 3 and words[2].isdigit():
                return int(words[2])
    raise ExportError(f"{path}: no 'element vertex' in the PLY header")


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


@contextmanager
def _atomic(path: Path) -> Iterator[Path]:
    """``with _atomic(path) as tmp``: write ``tmp``; it replaces ``path`` on success."""
    from causalsplat._atomic import atomic_target

    with atomic_target(path) as tmp:
        yield tmp
