"""Per-view masks of an answer's Gaussians, and the same masks drawn over each view's image."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from pathlib import Path

import numpy as np

from causalsplat.build.folder import find_ply, find_view_image, read_cameras, view_stem
from causalsplat.errors import MissingDependencyError
from causalsplat.export.source import check_hash, source_folder
from causalsplat.export.splats import labels_for
from causalsplat.io import read_gaussian_ply
from graph_store import SceneGraph

#: The overlay's colour for the answer (RGB).
ANSWER_RGB = (255, 48, 48)
#: Subfolder of the masks' folder that receives the overlays.
OVERLAY_DIR = "overlay"


def overlay_mask(image: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """``image`` with ``mask`` drawn over it: ``(H, W, 3)`` uint8.

    ``image``: ``(H, W, 3)`` uint8, or float in [0, 1] (a render); ``mask``: ``(H, W)``
    bool. Pixels of the mask are tinted half way to :data:`ANSWER_RGB` and its boundary
    pixels take that colour; the rest of the image is dimmed to 60 %, so the answer stands
    out in any scene.

    >>> out = overlay_mask(np.full((3, 4, 3), 100, np.uint8), np.eye(3, 4, dtype=bool))
    >>> out[0, 0].tolist(), out[0, 3].tolist()
    ([255, 48, 48], [60, 60, 60])
    """
    rgb = np.asarray(image)
    if rgb.dtype != np.uint8:
        rgb = np.clip(np.rint(rgb.astype(np.float64) * 255.0), 0, 255).astype(np.uint8)
    mask = np.asarray(mask, dtype=bool)
    if rgb.shape[:2] != mask.shape or rgb.ndim != 3 or rgb.shape[2] != 3:
        raise ValueError(f"image {rgb.shape} and mask {mask.shape} differ in size")
    out = rgb.astype(np.float64) * 0.6
    colour = np.asarray(ANSWER_RGB, dtype=np.float64)
    out[mask] = 0.5 * rgb[mask] + 0.5 * colour
    padded = np.pad(mask, 1, constant_values=False)
    interior = padded[:-2, 1:-1] & padded[2:, 1:-1] & padded[1:-1, :-2] & padded[1:-1, 2:] & mask
    out[mask & ~interior] = colour
    return np.clip(np.rint(out), 0, 255).astype(np.uint8)


def export_answer_masks(
    graph: SceneGraph,
    labels: np.ndarray | None,
    entity_ids: Iterable[int],
    out_dir: str | Path,
    *,
    source: str | Path | None = None,
    views: Sequence[str] | None = None,
    overlay: bool = False,
) -> list[Path]:
    """One PNG per view (``<stem>.png``, 255 where the answer is drawn, 0 elsewhere).

    A pixel belongs to the answer when the answer's Gaussians carry most of its blending
    weight (the other Gaussians still occlude) and its opacity reaches 0.5, as in
    :func:`~causalsplat.render.render_ids`. ``views``: image stems to render (default all).
    ``overlay``: also ``overlay/<stem>.png``, the mask over the view's image
    (:func:`overlay_mask`); the image is the scene folder's ``images/<stem>.*`` when it has
    the camera's size, else the view rendered from the Gaussians. Returns the paths, each
    view's mask before its overlay.
    """
    root = source_folder(graph, source)
    try:
        from PIL import Image
    except ImportError as exc:  # pillow ships with the field extra
        raise MissingDependencyError(
            "answer masks are written with pillow: pip install 'causalsplat[build]'"
        ) from exc

    from causalsplat.render import render_ids, render_rgb

    ply_path = find_ply(root)
    check_hash(graph, root, ply_path)
    scene = read_gaussian_ply(ply_path).scene
    ids = labels_for(graph, labels, scene.n)
    wanted = np.isin(ids, np.fromiter(entity_ids, dtype=np.int64)).astype(np.int64)
    # the build already decided about lens distortion (--allow-distortion)
    _, cameras = read_cameras(root, allow_distortion=True)
    keep = None if views is None else set(views)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    if overlay:
        (out / OVERLAY_DIR).mkdir(exist_ok=True)
    written = []
    for cam in cameras:
        stem = view_stem(cam.name)
        if keep is not None and stem not in keep:
            continue
        mask = render_ids(scene, cam, wanted) == 1
        path = out / f"{stem}.png"
        Image.fromarray((mask * 255).astype(np.uint8), mode="L").save(path)
        written.append(path)
        if overlay:
            image = find_view_image(root, stem, cam.width, cam.height)
            if image is None:
                image = render_rgb(scene, cam)
            drawn = out / OVERLAY_DIR / f"{stem}.png"
            Image.fromarray(overlay_mask(image, mask), mode="RGB").save(drawn)
            written.append(drawn)
    return written
