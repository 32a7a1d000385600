"""Lifting multi-view masks into a per-Gaussian feature field (the public entry points).

:func:`prepare_views` prunes Gaussians of negligible opacity, builds each view's cached
blending weights and its weighted mask matrix; :func:`lift_features` initialises the
features (training-free uplift or random) and refines them by contrastive training;
:func:`mask_evidence` gives each usable mask its feature ``Norm(sum W F)`` from the
final field and the weight each Gaussian carries inside it, all the instance stage needs.
Only :func:`lift_features` with ``iterations > 0`` imports torch.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
import scipy.sparse as sp

from causalsplat.errors import InputFormatError
from causalsplat.field.config import FieldConfig
from causalsplat.field.mask_gaussians import mask_gaussian_weights
from causalsplat.field.spill import (
    ContributorsCodec,
    RecomputedWeights,
    ViewMasksCodec,
    ViewSpill,
)
from causalsplat.field.types import FeatureField, MaskEvidence
from causalsplat.field.uplift import UpliftAccumulator
from causalsplat.field.weights import ViewMasks, mask_features, normalize_rows, view_masks
from causalsplat.io.types import Camera, GaussianScene
from causalsplat.masks import MaskSet
from causalsplat.render import RasterConfig, build_contributors
from causalsplat.render.types import Contributors

#: Compositing stops before the Gaussian that would leave less than this much light
#: (``RasterConfig.transmittance_min``) when the views' weights are built for lifting,
#: 1 % instead of the 1e-4 a rendered image uses. What lies behind 99 % opacity adds at
#: most 1 % to a pixel, yet such tails held most of a view's weights in dense scenes, and
#: they are the faint occluder votes of hidden Gaussians that the surface propagation
#: (:mod:`causalsplat.instances.propagate`) labels better. Measured with ``causalsplat build
#: --no-cache --json`` on the dev scenes (1e-4 -> 1e-2): scene0000_00 with default noise PQ
#: 0.756 -> 0.770, 9.5 -> 8.0 s, 1.68 -> 1.37 GB; exact masks 0.797 -> 0.789; every
#: Gaussian copied 8 times 0.656 -> 0.676, 50.3 -> 42.1 s, 5.54 -> 3.68 GB; synthetic small
#: seeds 0-2 0.879 / 0.873 / 0.867 -> 0.880 / 0.873 / 0.873; synthetic medium seed 0
#: (colour-weighted propagation on) 0.857 -> 0.827, but 0.826 at 1e-3 and 0.852 at 3e-3:
#: its clustering moves by that much with any small change. 3e-3 and 3e-2 were no better
#: over the dev scenes; the 1.46 M-Gaussian capture (docs/benchmarks.md, scale section)
#: builds in 26 % less time (with the colour weighting, 30 min 35 s -> 22 min 33 s).
LIFT_TRANSMITTANCE_MIN = 0.01
#: The rasterizer options a build lifts masks with by default (``BuildConfig.raster``).
LIFT_RASTER = RasterConfig(transmittance_min=LIFT_TRANSMITTANCE_MIN)
#: Where a build keeps its views' weights (see :func:`prepare_views`).
ViewStorage = Literal["auto", "memory", "disk", "recompute"]
VIEW_STORAGES: tuple[str, ...] = ("auto", "memory", "disk", "recompute")
#: Share of the budget of :func:`prepare_views` that the blending weights may keep
#: resident; the weighted masks get the rest.
_WEIGHTS_SHARE = 0.8
#: Share of that budget that the views' mask x blending-weight products may keep for
#: :func:`mask_evidence` (past it, it computes them again).
_MASK_GAUSSIANS_SHARE = 0.125


@dataclass(frozen=True, slots=True, eq=False)
class LiftedViews:
    """The views of a build, ready for lifting.

    Attributes:
        n_gaussians: N, Gaussians of the full scene.
        active: (N,) bool, Gaussians kept by the opacity pruning.
        contributors: per view, the blending weights of the *active* Gaussians (columns
            index ``np.flatnonzero(active)``): a tuple, or a sequence that reads a view
            from disk or rebuilds it when indexed (:mod:`causalsplat.field.spill`).
        masks: per view, its usable masks (:class:`ViewMasks`), held the same way.
        uplift: (n_active, C) float64 sum of the uplifted mask codes (``init="uplift"``),
            before normalisation, else ``None``.
        supervision: (n_active,) float64 blending weight of each Gaussian inside usable
            masks, all views.
        counts: how many views' weights stayed resident, went to disk, or are rebuilt
            at each use.
        mask_gaussians: per view, its (M, N_active) ``B @ W``
            (:func:`~causalsplat.field.mask_gaussians.mask_gaussian_weights`) where it
            was kept (within ``_MASK_GAUSSIANS_SHARE`` of the budget), else ``None``.

    The uplift and supervision are summed while the views are rasterized, so no pass
    reads the views again for them; the kept products spare :func:`mask_evidence` one.
    """

    n_gaussians: int
    active: np.ndarray
    contributors: Sequence[Contributors]
    masks: Sequence[ViewMasks]
    uplift: np.ndarray | None = None
    supervision: np.ndarray | None = None
    counts: dict[str, int] | None = None
    mask_gaussians: tuple[sp.csr_matrix | None, ...] = ()

    @property
    def spilled_bytes(self) -> int:
        """Bytes of view data written to disk (0 when every view stayed in memory)."""
        return sum(
            s.spilled_bytes for s in (self.contributors, self.masks) if isinstance(s, ViewSpill)
        )

    def close(self) -> None:
        """Remove the spilled files now (otherwise when the views are collected)."""
        for s in (self.contributors, self.masks):
            if isinstance(s, ViewSpill):
                s.close()


def prepare_views(
    scene: GaussianScene,
    cameras: Sequence[Camera],
    masksets: Sequence[MaskSet],
    config: FieldConfig,
    *,
    raster: RasterConfig = LIFT_RASTER,
    progress: Callable[[int], None] | None = None,
    storage: ViewStorage = "memory",
    budget_bytes: int | None = None,
    spill_dir: str | Path | None = None,
) -> LiftedViews:
    """Prune, rasterise each view once and weight its masks (module docstring).

    ``storage`` says where the views' blending weights stay between the passes that read
    them: ``memory`` (all resident), ``disk`` (written once and memory-mapped at each use),
    ``recompute`` (rebuilt by the rasterizer at each use, nothing kept) or ``auto``
    (resident while they fit ``budget_bytes``, the next ones on disk up to half its free
    space, the rest rebuilt at each use). The weighted masks stay
    resident, or, under ``auto`` and ``disk``, go to disk past their share of the budget.
    Disk files go to a private folder under ``spill_dir`` (default: the system's temporary
    directory), removed by :meth:`LiftedViews.close` or when the views are collected.
    """
    if len(cameras) != len(masksets):
        raise InputFormatError(f"{len(cameras)} cameras but {len(masksets)} mask sets")
    if storage not in VIEW_STORAGES:
        raise InputFormatError(f"storage={storage!r} must be one of {', '.join(VIEW_STORAGES)}")
    active = scene.opacities >= config.min_opacity
    sub = scene.subset(np.flatnonzero(active))
    rng = np.random.default_rng([config.seed, 1])
    unlimited = 1 << 62
    budget = unlimited if budget_bytes is None else max(0, int(budget_bytes))
    weight_budget = {"memory": unlimited, "disk": 0, "recompute": 0}.get(
        storage, int(budget * _WEIGHTS_SHARE)
    )
    mask_budget = unlimited if storage in ("memory", "recompute") else budget - weight_budget
    acc = UpliftAccumulator(
        int(active.sum()),
        config.feature_dim if config.init == "uplift" else None,
        np.random.default_rng([config.seed, 2]),  # the codes' generator
    )

    def rebuild(i: int) -> Contributors:
        return build_contributors(sub, cameras[i], config=raster, cache=False)

    disk = _disk_allowance(spill_dir) if storage == "auto" else None
    contribs = ViewSpill(
        ContributorsCodec(), weight_budget, spill_dir, disk_bytes=disk, rebuild=rebuild
    )
    vms = ViewSpill(ViewMasksCodec(), mask_budget, spill_dir)
    for cam, ms in zip(cameras, masksets, strict=True):
        if (ms.width, ms.height) != (cam.width, cam.height):
            raise InputFormatError(
                f"view {ms.view!r}: masks are {ms.width}x{ms.height} pixels, its camera "
                f"{cam.width}x{cam.height}"
            )
    products: list[sp.csr_matrix | None] = []
    product_bytes = 0
    for i, (cam, ms) in enumerate(zip(cameras, masksets, strict=True)):
        contrib = build_contributors(sub, cam, config=raster, cache=False)
        valid = contrib.alpha() >= config.min_pixel_alpha if config.min_pixel_alpha > 0 else None
        vm = view_masks(ms, i, config, rng, valid=valid)
        product = mask_gaussian_weights(vm, contrib) if vm.n_masks else None
        acc.add(contrib, vm, product)
        if product is not None:
            size = product.data.nbytes + product.indices.nbytes + product.indptr.nbytes
            if product_bytes + size > budget * _MASK_GAUSSIANS_SHARE:
                product = None
            else:
                product_bytes += size
        products.append(product)
        if storage != "recompute":
            contribs.append(contrib)
        vms.append(vm)
        del contrib, valid, vm, product
        if progress is not None:
            progress(i + 1)
    weights: Sequence[Contributors] = contribs
    if storage == "recompute":
        weights = RecomputedWeights(sub, cameras, raster)
    elif contribs.n_spilled == 0 and contribs.n_rebuilt == 0:
        weights = tuple(contribs)
    masks: Sequence[ViewMasks] = tuple(vms) if vms.n_spilled == 0 else vms
    n = len(cameras)
    counts = {
        "resident": n if storage == "memory" else n - contribs.n_spilled - contribs.n_rebuilt,
        "on_disk": contribs.n_spilled,
        "rebuilt": n if storage == "recompute" else contribs.n_rebuilt,
    }
    if storage == "recompute":
        counts["resident"] = 0
    return LiftedViews(
        scene.n, active, weights, masks, acc.codes, acc.supervision, counts, tuple(products)
    )


def _disk_allowance(spill_dir: str | Path | None) -> int:
    """Bytes ``auto`` may write to the spill folder: half its disk's free space now."""
    import shutil
    import tempfile

    where = Path(spill_dir) if spill_dir is not None else Path(tempfile.gettempdir())
    while not where.exists() and where != where.parent:
        where = where.parent
    return shutil.disk_usage(where).free // 2


def lift_features(
    views: LiftedViews,
    config: FieldConfig,
    *,
    progress: Callable[[int], None] | None = None,
) -> FeatureField:
    """Initialise and train the per-Gaussian features of ``views`` (module docstring)."""
    n_active = int(views.active.sum())
    if views.supervision is None or (config.init == "uplift" and views.uplift is None):
        raise InputFormatError("lift_features: the views were prepared without the sums it needs")
    if config.init == "uplift":
        assert views.uplift is not None
        if views.uplift.shape[1] != config.feature_dim:
            raise InputFormatError(
                f"lift_features: views prepared for feature_dim {views.uplift.shape[1]}, "
                f"config has {config.feature_dim}"
            )
        init = normalize_rows(views.uplift)
    else:
        rng = np.random.default_rng([config.seed, 2])
        init = normalize_rows(rng.standard_normal((n_active, config.feature_dim)))
    supervised = views.supervision > 0
    losses: tuple[float, ...] = ()
    feats = init
    if config.iterations > 0 and n_active > 0:
        from causalsplat.field.device import resolve_trainer

        if resolve_trainer(config, n_active) == "torch":
            from causalsplat.field.train_torch import train_features_torch as train
        else:
            from causalsplat.field.train import train_features as train
        feats, losses = train(views.contributors, views.masks, init, config, progress=progress)
    full = np.zeros((views.n_gaussians, config.feature_dim), dtype=np.float32)
    full[views.active] = normalize_rows(feats).astype(np.float32)
    sup = np.zeros(views.n_gaussians, dtype=bool)
    sup[views.active] = supervised
    return FeatureField(full, views.active.copy(), sup, losses, config)


def mask_evidence(
    field: FeatureField,
    views: LiftedViews,
    *,
    progress: Callable[[int], None] | None = None,
) -> MaskEvidence:
    """What the instance stage needs from the views, for every usable mask of every view:
    its feature ``Norm(sum W F)`` from the final field and the blending weight each
    Gaussian carries inside it (``sum_x W_m(x) w(x, g)``). ``progress(k)`` after view k.
    """
    active_idx = np.flatnonzero(views.active)
    active_feats = field.features[views.active].astype(np.float64)
    feats, blocks, view_of, index_of, pixel_weight = [], [], [], [], []
    for i, vm in enumerate(views.masks):
        if progress is not None:
            progress(i + 1)
        if vm.n_masks == 0:
            continue  # before reading the weights, which may be rebuilt to be read
        contrib = views.contributors[i]
        feature_map = np.zeros((vm.n_pixels, active_feats.shape[1]))
        feature_map[vm.pixels] = contrib.composite_rows(vm.pixels, active_feats)
        feats.append(mask_features(feature_map, vm))
        kept = views.mask_gaussians[i] if i < len(views.mask_gaussians) else None
        blocks.append(kept if kept is not None else mask_gaussian_weights(vm, contrib))
        view_of.append(np.full(vm.n_masks, vm.view, dtype=np.int64))
        index_of.append(vm.mask_index)
        pixel_weight.append(np.asarray(vm.weights.sum(axis=1), dtype=np.float64).ravel())
    n_masks = sum(f.shape[0] for f in feats)
    if n_masks:
        active_w = sp.vstack(blocks).tocsr()
        # Columns back to the full scene's Gaussian indices.
        full = sp.csr_matrix(
            (active_w.data, active_idx[active_w.indices], active_w.indptr),
            shape=(n_masks, views.n_gaussians),
        )
    else:
        full = sp.csr_matrix((0, views.n_gaussians), dtype=np.float64)
    return MaskEvidence(
        view=np.concatenate(view_of) if n_masks else np.zeros(0, np.int64),
        index=np.concatenate(index_of) if n_masks else np.zeros(0, np.int64),
        pixel_weight=np.concatenate(pixel_weight) if n_masks else np.zeros(0),
        features=np.concatenate(feats) if n_masks else np.zeros((0, field.dim), np.float32),
        gaussian_weight=full,
    )
