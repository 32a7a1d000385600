"""The labelled 3DGS PLY of a built scene, and per-view masks of an answer's Gaussians."""

from __future__ import annotations

import re
from collections.abc import Iterable, Sequence
from pathlib import Path

import numpy as np

from causalsplat.build.folder import find_ply, read_cameras, view_stem
from causalsplat.errors import MissingDependencyError
from causalsplat.export.source import ExportError, check_hash, source_folder
from causalsplat.io import read_gaussian_ply, write_ply
from graph_store import SceneGraph


def _labels_for(graph: SceneGraph, labels: np.ndarray | None, n: int) -> np.ndarray:
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
    per_entity_dir: str | Path | None = None,
) -> list[Path]:
    """Write the scene's 3DGS PLY with an ``entity_id`` vertex property (-1: none).

    With ``per_entity_dir``, also one PLY per entity, ``<id>_<category>.ply``. Returns the
    paths written. The PLY comes from the scene folder (see :mod:`causalsplat.export`).
    """
    root = source_folder(graph, source)
    ply_path = find_ply(root)
    check_hash(graph, root, ply_path)
    ply = read_gaussian_ply(ply_path)
    ids = _labels_for(graph, labels, ply.scene.n)
    extra = {k: v for k, v in ply.extra.items() if k != "entity_id"}
    out = Path(out)
    write_ply(out, ply.scene, extra={**extra, "entity_id": ids})
    written = [out]
    if per_entity_dir is not None:
        folder = Path(per_entity_dir)
        folder.mkdir(parents=True, exist_ok=True)
        for e in graph.entities:
            index = np.flatnonzero(ids == e.id)
            if index.size == 0:
                continue
            name = re.sub(r"[^A-Za-z0-9_.-]+", "_", e.category)
            path = folder / f"{e.id}_{name}.ply"
            sub = {k: v[index] for k, v in extra.items()}
            write_ply(path, ply.scene.subset(index), extra=sub)
            written.append(path)
    return written


def export_answer_masks(
    graph: SceneGraph,
    labels: np.ndarray | None,
    entity_ids: Iterable[int],
    out_dir: str | Path,
    *,
    source: str | Path | None = None,
    views: Sequence[str] | None = None,
) -> list[Path]:
    """One PNG per view (``<stem>.png``, 255 where the answer is drawn, 0 elsewhere).

    A pixel belongs to the answer when the answer's Gaussians carry most of its blending
    weight (the other Gaussians still occlude) and its opacity reaches 0.5, as in
    :func:`~causalsplat.render.render_ids`. ``views``: image stems to render (default all).
    """
    root = source_folder(graph, source)
    try:
        from PIL import Image
    except ImportError as exc:  # pillow ships with the field extra
        raise MissingDependencyError(
            "answer masks are written with pillow: pip install 'causalsplat[field]'"
        ) from exc

    from causalsplat.render import render_ids

    ply_path = find_ply(root)
    check_hash(graph, root, ply_path)
    scene = read_gaussian_ply(ply_path).scene
    ids = _labels_for(graph, labels, scene.n)
    wanted = np.isin(ids, np.fromiter(entity_ids, dtype=np.int64)).astype(np.int64)
    _, cameras = read_cameras(root)
    keep = None if views is None else set(views)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for cam in cameras:
        stem = view_stem(cam.name)
        if keep is not None and stem not in keep:
            continue
        mask = render_ids(scene, cam, wanted) == 1
        path = out / f"{stem}.png"
        Image.fromarray((mask * 255).astype(np.uint8), mode="L").save(path)
        written.append(path)
    return written
