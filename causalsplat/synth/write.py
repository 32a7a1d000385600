"""Turn a generated :class:`SynthScene` into its scene folder (DESIGN §9 layout)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from causalsplat.synth.config import SynthConfig
from causalsplat.synth.folder import (
    SceneFolderContent,
    check_output_dir,
    round_floats,
    write_scene_folder,
)
from causalsplat.synth.generate import SynthScene, generate_scene, stream
from causalsplat.synth.support import support_depth
from causalsplat.synth.vocab import Kind

#: Version tag of ``gt/scene.json`` written by the generator.
SCENE_FORMAT = "causalsplat-synth/1"


@dataclass(frozen=True, slots=True)
class SceneSummary:
    """What a written scene folder holds (printed by the CLI).

    Attributes:
        path: the folder.
        scene_id: the scene id used in ``objects.json`` and ``queries.json``.
        n_gaussians, n_views, n_entities, n_queries: counts.
        n_masks, n_gt_masks: masks over all views (written, and exact GT).
        queries_by_type: number of queries per reasoning type.
    """

    path: Path
    scene_id: str
    n_gaussians: int
    n_views: int
    n_entities: int
    n_queries: int
    n_masks: int
    n_gt_masks: int
    queries_by_type: dict[str, int]

    def to_json(self) -> dict[str, Any]:
        return {
            "path": str(self.path),
            "scene_id": self.scene_id,
            "n_gaussians": self.n_gaussians,
            "n_views": self.n_views,
            "n_entities": self.n_entities,
            "n_queries": self.n_queries,
            "n_masks": self.n_masks,
            "n_gt_masks": self.n_gt_masks,
            "queries_by_type": dict(self.queries_by_type),
            "files": {
                "point_cloud": str(self.path / "point_cloud.ply"),
                "cameras": str(self.path / "sparse" / "0"),
                "images": str(self.path / "images"),
                "masks": str(self.path / "masks"),
                "gt": str(self.path / "gt"),
                "objects": str(self.path / "objects.json"),
                "queries": str(self.path / "queries.json"),
            },
        }


def objects_document(scene: SynthScene) -> dict[str, Any]:
    """The ``objects.json`` document (DESIGN §9 objects input) of the GT entities."""
    rng = stream(scene.config.seed, "objects")
    means = scene.gaussians.means
    objects = []
    for obj in scene.layout.objects:
        index = np.flatnonzero(scene.labels == obj.id)
        k = min(scene.config.points_per_object, index.size)
        pick = np.sort(rng.choice(index, size=k, replace=False)) if k else index[:0]
        objects.append(
            {
                "id": obj.id,
                "label": obj.category,
                "center": round_floats(obj.center),
                "size": round_floats(obj.size),
                "points": round_floats(means[pick], 4),
                "attributes": {
                    "color": obj.color,
                    "material": obj.material,
                    "affordance": list(obj.affordances),
                },
            }
        )
    return {"scene_id": scene.scene_id, "units": "m", "up": "z", "objects": objects}


def queries_document(scene: SynthScene) -> dict[str, Any]:
    """The ``queries.json`` document (DESIGN §9 queries file)."""
    return {
        "scene_id": scene.scene_id,
        "queries": [
            {"id": q.id, "text": q.text, "type": q.type, "targets": list(q.targets)}
            for q in scene.queries
        ],
    }


def scene_document(scene: SynthScene) -> dict[str, Any]:
    """``gt/scene.json``: parameters, counts, and the GT entities with their supporters."""
    layout = scene.layout
    return {
        "format": SCENE_FORMAT,
        "scene_id": scene.scene_id,
        "units": "m",
        "up": "z",
        "cameras": "COLMAP text model in sparse/0 (OpenCV, world-to-camera)",
        "room_size_m": round_floats(layout.room_size),
        "config": scene.config.to_json(),
        "counts": {
            "gaussians": scene.gaussians.n,
            "views": len(scene.cameras),
            "entities": len(layout.objects),
            "furniture": len(layout.ids_of_kind(Kind.FURNITURE)),
            "small_objects": len(layout.ids_of_kind(Kind.SMALL)),
            "queries": len(scene.queries),
        },
        "views": [cam.name for cam in scene.cameras],
        "entities": [
            {
                "id": o.id,
                "category": o.category,
                "kind": str(o.kind),
                "color": o.color,
                "material": o.material,
                "affordances": list(o.affordances),
                "supporters": list(o.supporters),
                "support_depth": support_depth(layout, o.id),
                "center": round_floats(o.center),
                "size": round_floats(o.size),
            }
            for o in layout.objects
        ],
    }


def write_synth_scene(
    scene: SynthScene, out_dir: str | Path, *, overwrite: bool = False
) -> SceneSummary:
    """Write ``scene`` as a scene folder; returns its summary."""
    content = SceneFolderContent(
        gaussians=scene.gaussians,
        labels=scene.labels,
        cameras=scene.cameras,
        images=scene.images,
        masks=scene.masks,
        gt_masks=scene.gt_masks,
        objects=objects_document(scene),
        queries=queries_document(scene),
        scene_info=scene_document(scene),
    )
    path = write_scene_folder(out_dir, content, overwrite=overwrite)
    by_type: dict[str, int] = {}
    for q in scene.queries:
        by_type[q.type] = by_type.get(q.type, 0) + 1
    return SceneSummary(
        path=path,
        scene_id=scene.scene_id,
        n_gaussians=scene.gaussians.n,
        n_views=len(scene.cameras),
        n_entities=len(scene.layout.objects),
        n_queries=len(scene.queries),
        n_masks=sum(m.n for m in scene.masks),
        n_gt_masks=sum(m.n for m in scene.gt_masks),
        queries_by_type=by_type,
    )


def synth_scene(
    size: str,
    seed: int,
    out_dir: str | Path,
    *,
    noise_strength: float | None = None,
    overwrite: bool = False,
) -> SceneSummary:
    """Generate the ``size`` preset with ``seed`` and write it to ``out_dir`` (the CLI's work).

    The output folder is checked before anything is generated.
    """
    overrides = {} if noise_strength is None else {"noise_strength": float(noise_strength)}
    config = SynthConfig.preset(size, seed=seed, **overrides)
    check_output_dir(out_dir, overwrite=overwrite)
    return write_synth_scene(generate_scene(config), out_dir, overwrite=overwrite)
