"""``prepare_scannet``: a ScanNet scan as a scene folder (DESIGN §9 layout) with GT labels.

- Gaussians: one per mesh vertex, isotropic, standard deviation ``scale_factor`` times the
  mean distance to the ``k_neighbours`` nearest vertices (clipped), the vertex colour, one
  opacity.
- GT entity per Gaussian: the v2 objectId of its vertex (``ins_label - 1``), -1 unannotated.
- Cameras: ``n_walk_views`` walk-through views, then the real posed frames
  (:mod:`causalsplat.scannet.cameras`); images are renders for every view.
- Masks: exact instance masks from the id render (``gt/masks``), and the SAM-like noisy masks
  labelled with the object table's categories (``masks``).
- ``objects.json``: the object table (AABB centre and size, a vertex subsample, the mean
  colour of its vertices as ``rgb``, 0-255, as a built entity measures its own);
  ``queries.json``: the Sr3D / Nr3D / ScanRefer utterances (:mod:`causalsplat.scannet.language`).
- ``gt/photos/``: the real photos resized to the output size, and in ``gt/scene.json`` the
  render-vs-photo errors (:mod:`causalsplat.scannet.photo`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from causalsplat._checks import Interval, check_fields
from causalsplat.errors import CausalSplatError
from causalsplat.io.types import GaussianScene
from causalsplat.masks import NoiseConfig
from causalsplat.masks.noise import MAX_STRENGTH
from causalsplat.scannet.cameras import real_cameras, walk_cameras
from causalsplat.scannet.language import load_utterances
from causalsplat.scannet.photo import PhotoCheck, check_photos, load_photo
from causalsplat.scannet.source import ScanNetSource, load_scannet
from causalsplat.synth.folder import (
    SceneFolderContent,
    check_output_dir,
    round_floats,
    write_scene_folder,
)
from causalsplat.synth.generate import render_masked_views
from causalsplat.synth.write import SceneSummary

#: Version tag of ``gt/scene.json`` written by the adapter.
SCENE_FORMAT = "causalsplat-scannet/1"


class ScanNetConfigError(CausalSplatError, ValueError):
    """A :class:`ScanNetConfig` value is out of range."""


@dataclass(frozen=True, slots=True)
class ScanNetConfig:
    """Parameters of :func:`prepare_scannet` (pixels, metres, degrees)."""

    width: int = 320
    height: int = 240
    n_walk_views: int = 60
    fov_y_deg: float = 50.0
    eye_height_m: float = 1.5
    k_neighbours: int = 3
    scale_factor: float = 0.7
    min_scale_m: float = 0.003
    max_scale_m: float = 0.08
    opacity: float = 0.9
    noise_strength: float = 1.0
    noise: NoiseConfig = field(default_factory=NoiseConfig)
    seed: int = 0
    points_per_object: int = 64

    def __post_init__(self) -> None:
        if self.width < 8 or self.height < 8:
            raise ScanNetConfigError(
                f"ScanNetConfig: image size {self.width}x{self.height} is below 8x8 pixels"
            )
        if self.n_walk_views < 0:
            raise ScanNetConfigError(f"ScanNetConfig.n_walk_views={self.n_walk_views} < 0")
        check_fields(
            "ScanNetConfig",
            {"noise_strength": self.noise_strength, "seed": self.seed},
            {"noise_strength": Interval(0, MAX_STRENGTH), "seed": Interval(0, integer=True)},
            ScanNetConfigError,
        )

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, NoiseConfig):
                value = {g.name: getattr(value, g.name) for g in fields(value)}
                value["fragment_radius"] = list(value["fragment_radius"])
            out[f.name] = value
        return out


def gaussians_from_vertices(
    xyz: np.ndarray, rgb01: np.ndarray, config: ScanNetConfig
) -> GaussianScene:
    """One isotropic Gaussian per vertex (module docstring)."""
    dist, _ = cKDTree(xyz).query(xyz, k=config.k_neighbours + 1)
    spacing = dist[:, 1:].mean(axis=1)
    sigma = np.clip(config.scale_factor * spacing, config.min_scale_m, config.max_scale_m)
    return GaussianScene.from_points(xyz, rgb01, sigma, opacity=config.opacity)


def _objects_document(source: ScanNetSource, rng: np.random.Generator, k: int) -> dict[str, Any]:
    objects = []
    for obj in source.objects:
        index = np.flatnonzero(source.instance == obj.id)
        pick = np.sort(rng.choice(index, size=min(k, index.size), replace=False))
        objects.append(
            {
                "id": obj.id,
                "label": obj.label,
                "center": round_floats(obj.center),
                "size": round_floats(obj.size),
                "points": round_floats(source.xyz[pick], 4),
                "rgb": round_floats(source.rgb[index].mean(axis=0) * 255.0, 1),
            }
        )
    return {"scene_id": source.scan_id, "units": "m", "up": "z", "objects": objects}


def _scene_document(
    source: ScanNetSource, config: ScanNetConfig, names: list[str], checks: tuple[PhotoCheck, ...]
) -> dict[str, Any]:
    return {
        "format": SCENE_FORMAT,
        "scene_id": source.scan_id,
        "source": "ScanNet v2 (non-commercial research use; see the source folder's SOURCE.md)",
        "units": "m",
        "up": "z",
        "cameras": "COLMAP text model in sparse/0 (OpenCV, world-to-camera)",
        "config": config.to_json(),
        "counts": {
            "gaussians": int(source.xyz.shape[0]),
            "objects": len(source.objects),
            "annotated_gaussians": int((source.instance >= 0).sum()),
            "views": len(names),
        },
        "views": names,
        "photo_check": [
            {
                "view": c.view,
                "mae": round(c.mae, 3),
                "mae_shuffled": round(c.mae_shuffled, 3),
                "coverage": round(c.coverage, 4),
            }
            for c in checks
        ],
    }


def prepare_scannet(
    src_dir: str | Path,
    out_dir: str | Path,
    *,
    width: int = 320,
    height: int = 240,
    n_walk_views: int = 60,
    noise_strength: float = 1.0,
    seed: int = 0,
    overwrite: bool = False,
    scan_id: str = "scene0000_00",
    progress: Callable[[str], None] | None = None,
) -> SceneSummary:
    """Turn the ScanNet source folder ``src_dir`` into a scene folder at ``out_dir``;
    ``progress`` is called with one line as each step starts."""
    config = ScanNetConfig(
        width=width,
        height=height,
        n_walk_views=n_walk_views,
        noise_strength=noise_strength,
        seed=seed,
    )
    check_output_dir(out_dir, overwrite=overwrite)
    source = load_scannet(src_dir, scan_id)
    return write_scannet_scene(source, config, out_dir, overwrite=overwrite, progress=progress)


def scannet_content(
    source: ScanNetSource,
    config: ScanNetConfig,
    progress: Callable[[str], None] | None = None,
) -> SceneFolderContent:
    """Everything the scene folder of ``source`` holds under ``config`` (renders every view)."""
    say = progress or (lambda _line: None)
    say(f"{source.scan_id}: {len(source.xyz):,} vertices, {len(source.objects)} objects")
    gaussians = gaussians_from_vertices(source.xyz, source.rgb, config)
    labels = source.instance.astype(np.int32)
    w, h = config.width, config.height
    walk = walk_cameras(
        source,
        config.n_walk_views,
        w,
        h,
        fov_y_deg=config.fov_y_deg,
        eye_height_m=config.eye_height_m,
    )
    real = real_cameras(source, w, h)
    cameras = walk + real
    say(f"rendering {len(cameras)} views of {gaussians.n:,} Gaussians at {w}x{h}, with masks")
    views = render_masked_views(
        gaussians,
        labels,
        cameras,
        {o.id: o.label for o in source.objects},
        noise_strength=config.noise_strength,
        noise=config.noise,
        seed=config.seed,
    )
    say(f"checking the renders against {len(source.frames)} real photos")
    photos = tuple(load_photo(f.image, w, h) for f in source.frames)
    checks = check_photos(gaussians, real, photos, np.random.default_rng([config.seed, 7]))
    utterances = load_utterances(source)
    objects_rng = np.random.default_rng([config.seed, 6])
    return SceneFolderContent(
        gaussians=gaussians,
        labels=labels,
        cameras=cameras,
        images=views.images,
        masks=views.masks,
        gt_masks=views.gt_masks,
        objects=_objects_document(source, objects_rng, config.points_per_object),
        queries={
            "scene_id": source.scan_id,
            "queries": [
                {"id": u.id, "text": u.text, "type": u.type, "targets": list(u.targets)}
                for u in utterances
            ],
        },
        scene_info=_scene_document(source, config, [c.name for c in cameras], checks),
        extra_pngs=tuple(
            (f"gt/photos/{cam.name}.png", p) for cam, p in zip(real, photos, strict=True)
        ),
    )


def write_scannet_scene(
    source: ScanNetSource,
    config: ScanNetConfig,
    out_dir: str | Path,
    *,
    overwrite: bool = False,
    progress: Callable[[str], None] | None = None,
) -> SceneSummary:
    """Build every view of ``source`` under ``config`` and write the scene folder."""
    content = scannet_content(source, config, progress)
    if progress is not None:
        progress(f"writing {out_dir}")
    path = write_scene_folder(out_dir, content, overwrite=overwrite)
    n_queries = len(content.queries["queries"])
    return SceneSummary(
        path=path,
        scene_id=source.scan_id,
        n_gaussians=content.gaussians.n,
        n_views=len(content.cameras),
        n_entities=len(source.objects),
        n_queries=n_queries,
        n_masks=sum(m.n for m in content.masks),
        n_gt_masks=sum(m.n for m in content.gt_masks),
        queries_by_type={"spatial": n_queries},
    )
