"""Generate a synthetic scene in memory: layout, Gaussians, cameras, renders, masks, queries.

Randomness: one seed, split into independent streams (layout, Gaussians, cameras, queries,
and one noise stream per view), so the same seed always gives the same scene and changing
one stage's parameters leaves the others' draws untouched.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from causalsplat.io.types import Camera, GaussianScene
from causalsplat.masks import MaskSet, NoiseConfig, masks_from_id_render, perturb_masks
from causalsplat.synth._cameras import generate_cameras
from causalsplat.synth._gaussians import sample_gaussians
from causalsplat.synth._layout import RoomLayout, generate_layout
from causalsplat.synth._queries import GeneratedQuery, generate_queries
from causalsplat.synth.config import SynthConfig

_STREAMS = {"layout": 1, "gaussians": 2, "cameras": 3, "queries": 4, "noise": 5, "objects": 6}


def stream(seed: int, name: str, *extra: int) -> np.random.Generator:
    """The random stream ``name`` of a scene seed (independent of the other streams)."""
    return np.random.default_rng([int(seed), _STREAMS[name], *extra])


@dataclass(frozen=True, slots=True, eq=False)
class SynthScene:
    """A generated synthetic scene, everything in memory.

    Attributes:
        config: the parameters it was generated from.
        layout: entities (boxes) and their GT support structure.
        gaussians: the Gaussian scene, world frame (metres, z up).
        labels: (N,) int32 GT entity id per Gaussian.
        cameras: one camera per view, named by image stem (``view_000``...).
        images: (V, H, W, 3) uint8 rendered RGB, one per camera.
        gt_masks: per view, exact instance masks from the id render (labels = categories,
            ids = entity ids).
        masks: per view, the masks after the SAM-like noise model (what a build reads).
        queries: generated queries with GT targets (entity ids).
    """

    config: SynthConfig
    layout: RoomLayout
    gaussians: GaussianScene
    labels: np.ndarray
    cameras: tuple[Camera, ...]
    images: np.ndarray
    gt_masks: tuple[MaskSet, ...]
    masks: tuple[MaskSet, ...]
    queries: tuple[GeneratedQuery, ...]

    @property
    def scene_id(self) -> str:
        return f"synth-{self.config.size}-{self.config.seed}"


def render_views(
    gaussians: GaussianScene, labels: np.ndarray, cameras: tuple[Camera, ...]
) -> tuple[np.ndarray, list[np.ndarray]]:
    """RGB images (V, H, W, 3) uint8 and (H, W) int64 id maps of every camera."""
    from causalsplat.render.functional import render_ids, render_rgb

    images, id_maps = [], []
    for cam in cameras:
        rgb = render_rgb(gaussians, cam)
        images.append(np.rint(np.clip(rgb, 0.0, 1.0) * 255.0).astype(np.uint8))
        id_maps.append(render_ids(gaussians, cam, labels))
    return np.stack(images), id_maps


@dataclass(frozen=True, slots=True, eq=False)
class RenderedViews:
    """Renders and masks of every view.

    Attributes:
        images: (V, H, W, 3) uint8 RGB.
        gt_masks: per view, exact instance masks from the id render (``ids`` set).
        masks: per view, ``gt_masks`` after the SAM-like noise model.
    """

    images: np.ndarray
    gt_masks: tuple[MaskSet, ...]
    masks: tuple[MaskSet, ...]


def render_masked_views(
    gaussians: GaussianScene,
    labels: np.ndarray,
    cameras: tuple[Camera, ...],
    names: Mapping[int, str],
    *,
    noise_strength: float,
    noise: NoiseConfig,
    seed: int,
) -> RenderedViews:
    """Render every camera, cut GT masks from its id render (labelled by ``names``) and
    perturb them with the noise model (view ``k`` draws from the stream ``(seed, noise, k)``).
    """
    images, id_maps = render_views(gaussians, labels, cameras)
    gt = tuple(
        masks_from_id_render(ids, names, view=cam.name)
        for cam, ids in zip(cameras, id_maps, strict=True)
    )
    noisy = tuple(
        perturb_masks(m, noise_strength, stream(seed, "noise", k), noise) for k, m in enumerate(gt)
    )
    return RenderedViews(images=images, gt_masks=gt, masks=noisy)


def generate_scene(config: SynthConfig) -> SynthScene:
    """Generate the whole scene of ``config`` (deterministic in ``config.seed``)."""
    seed = config.seed
    layout = generate_layout(config, stream(seed, "layout"))
    sampled = sample_gaussians(layout, config, stream(seed, "gaussians"))
    cameras = generate_cameras(layout, config, stream(seed, "cameras"))
    views = render_masked_views(
        sampled.scene,
        sampled.labels,
        cameras,
        {o.id: o.category for o in layout.objects},
        noise_strength=config.noise_strength,
        noise=config.noise,
        seed=seed,
    )
    queries = generate_queries(layout, config.max_queries_per_type, stream(seed, "queries"))
    return SynthScene(
        config=config,
        layout=layout,
        gaussians=sampled.scene,
        labels=sampled.labels,
        cameras=cameras,
        images=views.images,
        gt_masks=views.gt_masks,
        masks=views.masks,
        queries=queries,
    )
