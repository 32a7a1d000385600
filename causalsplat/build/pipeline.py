"""The build pipeline: scene folder -> feature field -> 3D entities -> scene graph.

Stages, each timed (wall seconds and the process's peak RSS after it):

``load``        read the folder (PLY, cameras, masks, optional GT labels);
``rasterize``   prune Gaussians, build each view's blending weights, weight its masks;
``field``       training-free uplift and contrastive training of the features, then the
                mask evidence (features and per-Gaussian weights of every mask);
``instances``   HDBSCAN over mask features, an entity per Gaussian;
``graph``       entities (geometry, category, colour), spatial relations, provenance.

``rasterize`` and ``field`` are cached together under a key of the input file hashes and
the raster and field options; ``instances`` under that key and its own options. A re-run
with changed instance, node or edge options therefore reuses the field; changing only
node or edge options reuses the instances too. ``graph`` is cheap and always runs.

A stage that fails for a reason no check foresaw (an exception that is not a
:class:`~causalsplat.errors.CausalSplatError`) raises :class:`StageError`: one line that
names the folder and the stage, chained to the original, and nothing is stored.
"""

from __future__ import annotations

import dataclasses
import resource
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from causalsplat.build.cache import StageCache, cache_key, default_cache_dir, pack_csr, unpack_csr
from causalsplat.build.config import BuildConfig
from causalsplat.build.coverage import (
    Coverage,
    measure_coverage,
    median_depth,
    position_resolution,
    scene_near,
)
from causalsplat.build.errors import BuildError, CoverageError, StageError
from causalsplat.build.folder import SceneFolder, find_view_image, read_scene_folder
from causalsplat.build.huge_pages import huge_page_advice
from causalsplat.build.scale import scale_folder
from causalsplat.errors import CausalSplatError
from causalsplat.field import (
    FeatureField,
    MaskEvidence,
    lift_features,
    mask_evidence,
    prepare_views,
)
from causalsplat.field.blas import single_threaded_blas
from causalsplat.field.device import resolve_trainer
from causalsplat.graph import build_relations
from causalsplat.graph.contact import Surfaces
from causalsplat.graph.labeling import Labeler, label_entities
from causalsplat.graph.nodes import UNLABELLED, build_entities, build_provenance
from causalsplat.instances import (
    InstanceAssignment,
    InstanceQuality,
    assign_instances,
    scene_quality,
)
from graph_store import SceneGraph, SceneMeta

#: The masks read from the folder may keep 1 / _MASK_SHARE of the memory budget.
_MASK_SHARE = 8
#: Bumped when a cached stage's meaning changes, so old cache files are not reused
#: (2: masks reduced for ``image_scale < 1`` by a strict majority).
CACHE_VERSION = 2


@dataclass(frozen=True, slots=True)
class StageReport:
    """One stage of a build: wall seconds, whether it came from the cache, peak RSS (MiB)."""

    name: str
    seconds: float
    cached: bool
    peak_rss_mib: float


@dataclass(frozen=True, slots=True, eq=False)
class BuildResult:
    """What a build produced.

    Attributes:
        graph: the scene graph (entities, relations, views, masks, provenance).
        gaussian_labels: (N,) int32 entity id per Gaussian, -1 none.
        stages: the stage reports, in order.
        quality: instance quality against ``gt/gt_labels.npy`` when the folder has it.
        field: the feature field (``None`` when it came from the cache of a later stage).
        assignment: the instance assignment.
    """

    graph: SceneGraph
    gaussian_labels: np.ndarray
    stages: tuple[StageReport, ...]
    quality: InstanceQuality | None
    assignment: InstanceAssignment
    n_gaussians: int
    n_views: int
    warnings: tuple[str, ...] = ()
    coverage: Coverage | None = None
    views_storage: dict[str, Any] | None = None

    def to_json(self) -> dict[str, Any]:
        g = self.graph
        return {
            "scene_id": g.scene_id,
            "gaussians": self.n_gaussians,
            "views": self.n_views,
            "masks": len(g.masks),
            "entities": len(g.entities),
            "relations": len(g.relations),
            "clusters": self.assignment.n_clusters,
            "noise_masks": self.assignment.n_noise_masks,
            "unassigned_gaussians": int((self.gaussian_labels < 0).sum()),
            "stages": [
                {
                    "name": s.name,
                    "seconds": round(s.seconds, 3),
                    "cached": s.cached,
                    "peak_rss_mib": round(s.peak_rss_mib, 1),
                }
                for s in self.stages
            ],
            "total_seconds": round(sum(s.seconds for s in self.stages), 3),
            "peak_rss_mib": round(max((s.peak_rss_mib for s in self.stages), default=0.0), 1),
            "quality": None if self.quality is None else self.quality.to_json(),
            "warnings": list(self.warnings),
            "coverage": None if self.coverage is None else self.coverage.to_json(),
            "views_storage": self.views_storage,
        }


def _peak_rss_mib() -> float:
    """This process's peak resident memory, MiB.

    On Linux ``VmHWM`` of ``/proc/self/status``: ``ru_maxrss`` is carried over from the
    parent through fork and exec, so a build run by a large process (a benchmark, a
    notebook) would report the parent's peak.
    """
    try:
        with open("/proc/self/status", encoding="ascii") as status:
            for line in status:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024
    except (OSError, ValueError, IndexError):
        pass
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak / (1024 * 1024) if sys.platform == "darwin" else peak / 1024


class _Stages:
    """Times the stages of one build; ``where`` (the scene folder) names it in errors."""

    def __init__(self, where: str, lines: bool = False) -> None:
        self.where = where
        self.lines = lines
        self.reports: list[StageReport] = []

    @contextmanager
    def stage(self, name: str, cached: bool = False) -> Iterator[None]:
        """Time the block as stage ``name``. An exception in it that is not a
        :class:`~causalsplat.errors.CausalSplatError` (those already say what went wrong)
        becomes a :class:`StageError` naming the folder and the stage, chained to it."""
        start = time.perf_counter()
        try:
            yield
        except CausalSplatError:
            raise
        except Exception as exc:
            raise StageError(self.where, name, exc) from exc
        report = StageReport(name, time.perf_counter() - start, cached, _peak_rss_mib())
        self.reports.append(report)
        if self.lines:
            tag = " (cached)" if cached else ""
            print(
                f"causalsplat: {name} done{tag} in {report.seconds:.1f} s, "
                f"peak memory {report.peak_rss_mib:.0f} MiB",
                file=sys.stderr,
                flush=True,
            )


def build_scene(
    path: str | Path,
    *,
    scene_id: str | None = None,
    config: BuildConfig | None = None,
    cache_dir: str | Path | bool | None = True,
    progress: bool = False,
    labeler: Labeler | None = None,
) -> BuildResult:
    """Build the scene graph of a scene folder (docs/formats.md) and return it with its report.

    ``scene_id`` defaults to the ``scene_id`` of the folder's ``queries.json`` or
    ``objects.json``, else the folder's name. ``cache_dir``: a directory, ``True`` for the
    default (``$CAUSALSPLAT_CACHE`` or ``~/.cache/causalsplat``), or ``False``/``None`` for
    no cache. ``progress`` shows progress on stderr (bars on a terminal, else lines,
    one per stage too). ``labeler`` names the entities
    from their crops (default: the VLM one when ``config.labeler == "vlm"``, else none:
    the mask vote stands). Raises :class:`~causalsplat.errors.InputFormatError` (subclasses
    name the file) for a malformed folder or config, :class:`BuildError` when there is
    nothing to build from, the VLM errors of the labeller, and :class:`StageError` (a
    :class:`BuildError`, one line naming the stage) for any other failure inside a stage.
    """
    config = config or BuildConfig()
    with single_threaded_blas(), huge_page_advice(config.huge_pages):
        return _build(Path(path), scene_id, config, cache_dir, progress, labeler)


def _build(
    path: Path,
    scene_id: str | None,
    config: BuildConfig,
    cache_dir: str | Path | bool | None,
    progress: bool,
    labeler: Labeler | None,
) -> BuildResult:
    resolve_trainer(config.field)  # a device this machine lacks fails before any work
    cache = StageCache(default_cache_dir() if cache_dir is True else (cache_dir or None))
    stages = _Stages(str(path), lines=progress and not sys.stderr.isatty())
    with stages.stage("load"):
        folder, config, near_note = _load(path, config)
        hashes = _result_hashes(folder)
        coverage = check_coverage(folder, config)
    result = config.result_json()  # less the speed-only options
    field_key = cache_key(
        CACHE_VERSION, hashes, result["raster"], result["field"], result["image_scale"]
    )
    field, evidence, storage = _field_stage(folder, config, cache, field_key, stages, progress)
    if evidence.n == 0:
        raise BuildError(
            f"{folder.root}: no usable mask: none of the {len(folder.cameras)} views draws a "
            f"Gaussian (accumulated alpha >= {config.field.min_pixel_alpha}) under a mask of "
            f"at least {config.field.min_mask_pixels} px; check that the cameras look at the "
            f"scene, the masks match the images, and the near plane (raster.near = "
            f"{config.raster.near} scene units) suits the scene's scale"
        )
    inst_key = cache_key(field_key, result["instances"])
    cached = cache.get("instances", inst_key)
    with stages.stage("instances", cached=cached is not None):
        if cached is not None:
            assignment = _decode_assignment(cached)
        else:
            assignment = assign_instances(
                field, evidence, config.instances,
                means=folder.gaussians.means, scales=folder.gaussians.scales,
                quats=folder.gaussians.quats, mask_labels=mask_labels(folder, evidence),
                colors=folder.gaussians.colors,
            )  # fmt: skip
            cache.put("instances", inst_key, _encode_assignment(assignment))
    if labeler is None and config.labeler == "vlm":
        from causalsplat.openai_compat import VLMLabeler

        labeler = VLMLabeler()
    with stages.stage("graph"):
        graph = _graph(folder, evidence, assignment, config, scene_id, hashes, labeler)
    quality = None
    if folder.gt_labels is not None:
        quality = scene_quality(assignment.labels, folder.gt_labels)
    warnings = [note for note in (near_note, _coarse_positions(folder)) if note is not None]
    if folder.distorted:
        warnings.append(
            f"lens distortion dropped (--allow-distortion): {'; '.join(folder.distorted)};"
            " masks sit where a pinhole camera would put them, off by the distortion;"
            " undistort the images first (colmap image_undistorter) for exact geometry"
        )
    if labeler is None and all(m.labels is None for m in folder.masks):
        warnings.append(
            "the masks carry no labels and no labeller was given: every entity is stored as"
            f" {UNLABELLED!r}, so instructions cannot name them; add labels to the masks"
            " or build with --labeler vlm"
        )
    return BuildResult(
        graph=graph,
        gaussian_labels=assignment.labels.astype(np.int32),
        stages=tuple(stages.reports),
        quality=quality,
        assignment=assignment,
        n_gaussians=folder.gaussians.n,
        n_views=len(folder.cameras),
        warnings=tuple(warnings),
        coverage=coverage,
        views_storage=storage,
    )


def _load(path: Path, config: BuildConfig) -> tuple[SceneFolder, BuildConfig, str | None]:
    """The folder as the build reads it (views, masks scaled to the budget), and the config
    with its near plane suited to the scene's scale (and the note saying so)."""
    folder = read_scene_folder(
        path, max_views=config.max_views, allow_distortion=config.allow_distortion,
        mask_budget=config.memory_budget_bytes() // _MASK_SHARE,
    )  # fmt: skip
    folder = scale_folder(folder, config.image_scale, config.memory_budget_bytes() // _MASK_SHARE)
    config, near_note = _near_for_scale(folder, config)
    return folder, config, near_note


def build_field(
    path: str | Path, config: BuildConfig | None = None
) -> tuple[SceneFolder, BuildConfig, FeatureField, MaskEvidence]:
    """The stages before the instances, as :func:`build_scene` runs them, uncached: the
    folder as read, the config in force, the feature field and the mask evidence. For
    analyses of the instance stage: ``assign_instances`` on them, given the folder's
    Gaussians (``means``, ``scales``, ``quats``, ``colors``) and ``mask_labels``, is the
    build's."""
    config = config or BuildConfig()
    with single_threaded_blas():
        resolve_trainer(config.field)
        folder, config, _ = _load(Path(path), config)
        field, evidence, _ = _field_stage(folder, config, StageCache(None), "", _Stages(str(path)),
                                          False)  # fmt: skip
    return folder, config, field, evidence


#: Coordinates rounded (float32) to more than this share of the Gaussians' median size are
#: reported: the scene lies too far from the origin for its positions to hold its shapes.
COARSE_POSITIONS = 0.1


def _coarse_positions(folder: SceneFolder) -> str | None:
    """A note when the Gaussians' float32 positions are rounded coarsely for their size."""
    far, step, size = position_resolution(folder.gaussians.means, folder.gaussians.log_scales)
    if size <= 0 or step <= COARSE_POSITIONS * size:
        return None
    return (
        f"the Gaussians' float32 positions reach {far:.3g} units from the origin, where they"
        f" are rounded to {step:.3g} units, against a median Gaussian size of {size:.3g}:"
        " recentre the scene (subtract its centre from the positions and the camera"
        " centres) before training and exporting it"
    )


def _near_for_scale(folder: SceneFolder, config: BuildConfig) -> tuple[BuildConfig, str | None]:
    """``config`` with its near plane brought within the scene's scale
    (:func:`~causalsplat.build.coverage.scene_near`), and a note when it was lowered."""
    depth = median_depth(folder.gaussians.means, folder.cameras)
    near = scene_near(config.raster.near, depth)
    if near >= config.raster.near:
        return config, None
    note = (
        f"raster.near lowered from {config.raster.near:g} to {near:.3g} scene units: the"
        f" Gaussians lie a median {depth:.3g} units from the cameras (a scene in other units"
        " than metres); set raster.near in the build config to choose it"
    )
    raster = dataclasses.replace(config.raster, near=near)
    return dataclasses.replace(config, raster=raster), note


def check_coverage(folder: SceneFolder, config: BuildConfig) -> Coverage:
    """Measure how the folder's cameras and masks meet its Gaussians; raise
    :class:`CoverageError` when a share is below the config's threshold."""
    coverage = measure_coverage(
        folder.gaussians.means, folder.cameras, folder.masks, near=config.raster.near
    )
    if coverage.seen < config.min_seen or coverage.masked < config.min_masked:
        coarse = _coarse_positions(folder)
        if coarse is not None:
            raise CoverageError(f"{folder.root}: {coarse}")
        raise CoverageError(
            f"{folder.root}: the PLY and the cameras do not look like one capture: the "
            f"{len(folder.cameras)} views see {coverage.seen:.1%} of the Gaussians (at least "
            f"{config.min_seen:.0%} needed) and {coverage.masked:.1%} of the mask pixels fall "
            f"where a Gaussian projects (at least {config.min_masked:.0%} needed); check that "
            "the cameras and masks come from the capture the PLY was trained on and that the "
            f"near plane (raster.near = {config.raster.near} scene units) suits the scene's "
            "scale (min_seen and min_masked in the build config set the thresholds, 0 turns a "
            "check off)"
        )
    return coverage


def _field_stage(
    folder: SceneFolder,
    config: BuildConfig,
    cache: StageCache,
    key: str,
    stages: _Stages,
    progress: bool,
) -> tuple[FeatureField, MaskEvidence, dict[str, Any] | None]:
    cached = cache.get("field", key)
    if cached is not None:
        with stages.stage("field", cached=True):
            return _decode_field(cached, config), _decode_evidence(cached), None
    with stages.stage("rasterize"), _bar(len(folder.cameras), "rasterize", progress) as tick:
        views = prepare_views(
            folder.gaussians, folder.cameras, folder.masks, config.field,
            raster=config.raster, progress=tick, storage=config.views,
            budget_bytes=config.memory_budget_bytes(),
        )  # fmt: skip
    try:
        with stages.stage("field"):
            with _bar(config.field.iterations, "field", progress) as tick:
                field = lift_features(views, config.field, progress=tick)
            with _bar(len(views.masks), "evidence", progress) as tick:
                evidence = mask_evidence(field, views, progress=tick)
    finally:
        storage = {
            "storage": config.views,
            **(views.counts or {}),
            "spilled_mib": round(views.spilled_bytes / 2**20, 1),
        }
        views.close()
    cache.put("field", key, {**_encode_field(field), **_encode_evidence(evidence)})
    return field, evidence, storage


@contextmanager
def _bar(total: int, name: str, enabled: bool) -> Iterator[Callable[[int], None] | None]:
    """Progress of a stage on stderr: a bar on a terminal, else lines (for logs)."""
    if not enabled or total == 0:
        yield None
        return
    if not sys.stderr.isatty():
        yield _ProgressLines(total, name).tick
        return
    from tqdm import tqdm

    with tqdm(total=total, desc=name, unit="step", file=sys.stderr, leave=False) as bar:

        def tick(done: int) -> None:
            bar.update(done - bar.n)

        yield tick


class _ProgressLines:
    """``causalsplat: rasterize 40/200 (20%), 12.3 s`` on stderr at each tenth of the
    work and at least every ``every`` seconds, and at the end."""

    def __init__(self, total: int, name: str, every: float = 30.0) -> None:
        self.total, self.name, self.every = total, name, every
        self.start = self.last = time.perf_counter()
        self.step = max(1, -(-total // 10))

    def tick(self, done: int) -> None:
        now = time.perf_counter()
        if done % self.step and done != self.total and now - self.last < self.every:
            return
        self.last = now
        print(
            f"causalsplat: {self.name} {done}/{self.total} ({done / self.total:.0%}), "
            f"{now - self.start:.1f} s",
            file=sys.stderr,
            flush=True,
        )


def _graph(
    folder: SceneFolder,
    evidence: MaskEvidence,
    assignment: InstanceAssignment,
    config: BuildConfig,
    scene_id: str | None,
    hashes: dict[str, str],
    labeler: Labeler | None,
) -> SceneGraph:
    entities = build_entities(folder.gaussians, assignment, evidence, folder.masks, config.nodes)
    if not entities:
        raise BuildError(
            f"{folder.root}: the build found no entities ({len(folder.masks)} views of masks"
            f" over {folder.gaussians.n} Gaussians); nothing was stored. Check that the masks"
            " and cameras belong to this PLY, or lower instances.min_gaussians"
        )
    if labeler is not None:
        entities = label_entities(entities, assignment, evidence, folder.masks,
                                  lambda v: view_image(folder, v), labeler)  # fmt: skip
    relations = build_relations(entities, config.edges, up_axis=config.up_axis,
                                surfaces=_surfaces(folder, assignment, config))  # fmt: skip
    views, masks = build_provenance(
        folder.cameras, folder.masks, evidence, assignment, {e.id for e in entities}
    )
    meta = SceneMeta(
        scene_id=scene_id_of(folder.root, scene_id),
        units=config.units,
        up_axis=config.up_axis,
        source="build",
        config_hash=cache_key(config.result_json()),
        provenance=(*sorted(hashes.items()), ("source_dir", str(folder.root))),
    )
    return SceneGraph(meta=meta, entities=entities, relations=relations, views=views,
                      masks=masks)  # fmt: skip


def mask_labels(folder: SceneFolder, evidence: MaskEvidence) -> list[str | None] | None:
    """The label of each usable mask (rows of ``evidence``), ``None`` where its view's
    masks carry none; ``None`` when no view's do."""
    if all(m.labels is None for m in folder.masks):
        return None
    return [
        None if (labels := folder.masks[int(v)].labels) is None else str(labels[int(i)])
        for v, i in zip(evidence.view, evidence.index, strict=True)
    ]


def _surfaces(
    folder: SceneFolder, assignment: InstanceAssignment, config: BuildConfig
) -> Surfaces | None:
    """Each entity's Gaussian centres and the contact radius of the support rule
    (``EdgeConfig.contact_scales`` median Gaussian sizes); ``None`` when turned off."""
    factor = config.edges.contact_scales
    labels = assignment.labels
    kept = labels >= 0
    if factor == 0 or not kept.any():
        return None
    size = float(np.median(np.max(np.asarray(folder.gaussians.scales)[kept], axis=1)))
    if not (np.isfinite(size) and size > 0):
        return None
    means = np.asarray(folder.gaussians.means)
    order = np.argsort(labels[kept], kind="stable")
    ids, starts = np.unique(labels[kept][order], return_index=True)
    points = dict(zip(ids.tolist(), np.split(means[kept][order], starts[1:]), strict=True))
    return Surfaces(points, radius=factor * size)


def view_image(folder: SceneFolder, view: int) -> np.ndarray:
    """View ``view``'s image: ``images/<stem>.*`` when the folder has it, else rendered."""
    cam = folder.cameras[view]
    found = find_view_image(folder.root, folder.masks[view].view, cam.width, cam.height)
    if found is not None:
        return found
    from causalsplat.render import render_rgb

    return render_rgb(folder.gaussians, cam)


def _declared_in(paths: tuple[Path | None, ...]) -> str | None:
    import json

    for path in paths:
        if path is None or not path.is_file():
            continue
        try:
            value = json.loads(path.read_text(encoding="utf-8")).get("scene_id")
        except (OSError, UnicodeDecodeError, ValueError, AttributeError):
            continue
        if isinstance(value, str) and value:
            return value
    return None


def _result_hashes(folder: SceneFolder) -> dict[str, str]:
    """The input hashes a build's result depends on (the GT labels only score it)."""
    return {k: v for k, v in folder.input_hashes().items() if not k.startswith("gt/")}


def scene_input_hashes(path: str | Path, config: BuildConfig | None = None) -> dict[str, str]:
    """The input file hashes :func:`build_scene` would record in the provenance of the
    scene built from ``path`` with ``config`` (the files it reads, as it picks them: the
    PLY, the camera files, the mask files of the views ``max_views`` keeps). Reads the
    folder as the ``load`` stage does, without the later stages, so a batch can tell an
    already stored scene from one whose inputs changed."""
    config = config or BuildConfig()
    folder = read_scene_folder(
        path, max_views=config.max_views, allow_distortion=config.allow_distortion,
        mask_budget=config.memory_budget_bytes() // _MASK_SHARE,
    )  # fmt: skip
    return _result_hashes(folder)


def scene_id_of(path: str | Path, scene_id: str | None = None) -> str:
    """The id :func:`build_scene` stores the folder ``path`` under: ``scene_id``, else the
    ``scene_id`` of its ``queries.json`` or ``objects.json``, else the folder's name. Reads
    only those two files, so a store can refuse a build before it runs.

    >>> scene_id_of("/data/scans/kitchen"), scene_id_of("/data/kitchen", "k1")
    ('kitchen', 'k1')
    """
    root = Path(path).absolute()
    declared = _declared_in((root / "queries.json", root / "objects.json"))
    return scene_id or declared or root.name


# -- cache encoding ----------------------------------------------------------------------


def _encode_field(field: FeatureField) -> dict[str, np.ndarray]:
    return {
        "features": field.features,
        "active": field.active,
        "supervised": field.supervised,
        "losses": np.asarray(field.losses, dtype=np.float64),
    }


def _decode_field(a: dict[str, np.ndarray], config: BuildConfig) -> FeatureField:
    return FeatureField(
        a["features"], a["active"], a["supervised"], tuple(a["losses"].tolist()), config.field
    )


def _encode_evidence(e: MaskEvidence) -> dict[str, np.ndarray]:
    return {
        "ev_view": e.view,
        "ev_index": e.index,
        "ev_pixel_weight": e.pixel_weight,
        "ev_features": e.features,
        **pack_csr("ev_w", e.gaussian_weight),
    }


def _decode_evidence(a: dict[str, np.ndarray]) -> MaskEvidence:
    return MaskEvidence(
        a["ev_view"], a["ev_index"], a["ev_pixel_weight"], a["ev_features"], unpack_csr("ev_w", a)
    )


def _encode_assignment(s: InstanceAssignment) -> dict[str, np.ndarray]:
    return {
        "labels": s.labels,
        "mask_entity": s.mask_entity,
        "centers": s.centers,
        "score": s.score,
        "counts": np.asarray([s.n_clusters, s.n_noise_masks], dtype=np.int64),
    }


def _decode_assignment(a: dict[str, np.ndarray]) -> InstanceAssignment:
    n_clusters, n_noise = (int(v) for v in a["counts"])
    return InstanceAssignment(
        a["labels"], a["mask_entity"], a["centers"], a["score"], n_clusters, n_noise
    )
