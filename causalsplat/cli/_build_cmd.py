"""The build command: a scene folder to a stored scene graph."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import click

from causalsplat.cli._app import cli, db_option, echo_json, fail, json_option

if TYPE_CHECKING:
    from causalsplat.build import BuildConfig

F = TypeVar("F")

_UNITS = {"K": 2**-10, "M": 1, "G": 2**10, "T": 2**20}


def parse_mib(text: str) -> int:
    """MiB of a size such as ``12G``, ``800M``, ``512K`` or ``2048`` (MiB).

    >>> parse_mib("12G"), parse_mib("800m"), parse_mib("2048"), parse_mib("1.5G")
    (12288, 800, 2048, 1536)
    """
    value = text.strip().upper().removesuffix("IB").removesuffix("B")
    factor = _UNITS.get(value[-1:]) if value else None
    number = value[:-1] if factor is not None else value
    try:
        mib = float(number) * (factor or 1)
    except ValueError:
        fail(f"--memory-budget {text!r}: expected a size such as 12G, 800M or 2048 (MiB)")
    if not mib >= 0 or mib == float("inf"):
        fail(f"--memory-budget {text!r}: must be in [0, inf)")
    return int(mib)


_BUILD_OPTIONS = [
    click.option(
        "--config",
        "config_file",
        type=click.Path(dir_okay=False, path_type=Path),
        help="JSON file of build options (sections raster, field, instances, nodes, edges).",
    ),
    click.option(
        "--max-views", type=click.IntRange(min=1), help="Use at most N evenly spaced views."
    ),
    click.option(
        "--cache-dir",
        type=click.Path(file_okay=False, path_type=Path),
        help="Stage cache directory (default $CAUSALSPLAT_CACHE or ~/.cache/causalsplat).",
    ),
    click.option("--no-cache", is_flag=True, help="Compute every stage; read and write no cache."),
    click.option(
        "--labeler",
        type=click.Choice(["masks", "vlm"]),
        default=None,
        help="Who names the entities: the mask labels' vote (default) or a VLM server "
        "($CAUSALSPLAT_VLM_BASE_URL, $CAUSALSPLAT_VLM_MODEL) looking at each entity's crop.",
    ),
    click.option(
        "--allow-distortion",
        is_flag=True,
        help="Read COLMAP cameras with lens distortion as pinhole cameras (with a warning) "
        "instead of refusing them; undistorting first (colmap image_undistorter) is exact.",
    ),
    click.option(
        "--image-scale",
        type=click.FloatRange(min=0, max=1, min_open=True),
        help="Work at this fraction of the masks' resolution, in (0, 1] (cameras and masks "
        "scaled down; time and memory of the views fall with its square).",
    ),
    click.option(
        "--threads",
        type=click.IntRange(min=1),
        help="Threads of the rasterizer (default: the cores this process may use; build-many: "
        "the cores divided between its workers); the training's small steps run on one.",
    ),
    click.option(
        "--memory-budget",
        metavar="SIZE",
        help="Memory the views' data may keep, e.g. 12G or 800M (default: a quarter of the RAM; "
        "build-many: divided between its workers); views past it are memory-mapped from a "
        "temporary folder.",
    ),
    click.option(
        "--views",
        type=click.Choice(["auto", "memory", "disk", "recompute"]),
        help="Where the views' weights stay between passes: auto (memory up to the budget, "
        "then disk), memory, disk, or recompute (rasterized again at each use).",
    ),
    click.option(
        "--device",
        type=click.Choice(["auto", "cpu", "cuda"]),
        help="Where the feature field trains: auto (default: a CUDA GPU that torch sees, on "
        "torch; else the CPU, on the numpy trainer), cpu, or cuda (torch; fails without one).",
    ),
]


def build_options(func: F) -> F:
    """The options of ``build`` that set the build config and the stage cache (shared with
    ``build-many``, where they apply to each scene)."""
    for option in reversed(_BUILD_OPTIONS):
        func = option(func)
    return func


def config_from_options(
    config_file: Path | None,
    max_views: int | None,
    labeler: str | None,
    allow_distortion: bool,
    image_scale: float | None,
    threads: int | None,
    memory_budget: str | None,
    views: str | None,
    device: str | None = None,
) -> BuildConfig:
    """The build config of the config file (or the defaults) and the options given."""
    from causalsplat.build import BuildConfig

    config = BuildConfig.from_file(config_file) if config_file else BuildConfig()
    if max_views is not None:
        config = dataclasses.replace(config, max_views=max_views)
    if labeler is not None:
        config = dataclasses.replace(config, labeler=labeler)
    if allow_distortion:
        config = dataclasses.replace(config, allow_distortion=True)
    if image_scale is not None:
        config = dataclasses.replace(config, image_scale=image_scale)
    if threads is not None:
        config = dataclasses.replace(
            config, raster=dataclasses.replace(config.raster, threads=threads)
        )
    if memory_budget is not None:
        config = dataclasses.replace(config, memory_budget_mib=parse_mib(memory_budget))
    if views is not None:
        config = dataclasses.replace(config, views=views)  # type: ignore[arg-type]
    if device is not None:
        field = dataclasses.replace(config.field, device=device)  # type: ignore[arg-type]
        config = dataclasses.replace(config, field=field)
    return config


def panoptic_line(q: dict[str, Any]) -> str:
    """The panoptic figures of a build's quality document, in one phrase."""

    def num(x: float | None) -> str:
        return "n/a" if x is None else f"{x:.3f}"

    return (
        f"PQ {num(q['pq'])} (SQ {num(q['sq'])}, RQ {num(q['rq'])}) over GT objects of "
        f">= {q['panoptic_min_size']} Gaussians: {q['split']} split, {q['merged']} merged, "
        f"{q['missed']} missed, {q['extra']} extra"
    )


@cli.command("build")
@click.argument("scene_dir", type=click.Path(file_okay=False, path_type=Path))
@click.option(
    "--scene",
    "scene_id",
    help="Scene id (default: the scene_id of the folder's queries.json or objects.json, "
    "else the folder's name).",
)
@click.option(
    "--if-exists",
    type=click.Choice(["fail", "replace"]),
    default="fail",
    show_default=True,
    help="What to do when a scene with this id is already stored.",
)
@build_options
@click.option(
    "--progress/--no-progress",
    default=None,
    help="Progress on stderr: bars on a terminal, lines otherwise (default: on, off with --json).",
)
@db_option
@json_option
def build(
    scene_dir: Path,
    scene_id: str | None,
    config_file: Path | None,
    max_views: int | None,
    if_exists: str,
    cache_dir: Path | None,
    no_cache: bool,
    labeler: str | None,
    allow_distortion: bool,
    image_scale: float | None,
    threads: int | None,
    memory_budget: str | None,
    views: str | None,
    device: str | None,
    progress: bool | None,
    db_url: str,
    as_json: bool,
) -> None:
    """Build a scene folder (3DGS PLY, cameras, masks) into a stored scene graph.

    Runs the method: masks lifted into a feature field, HDBSCAN entities, spatial edges;
    stores the graph and the entity of every Gaussian. --json prints stage timings, peak
    memory and, when the folder has gt/gt_labels.npy, the instance quality.
    """
    from causalsplat.api import open_store

    config = config_from_options(config_file, max_views, labeler, allow_distortion, image_scale,
                                 threads, memory_budget, views, device)  # fmt: skip
    cache: Path | bool = False if no_cache else (cache_dir or True)
    with open_store(db_url) as store:
        scene = store.build(
            scene_dir,
            scene_id=scene_id,
            config=config,
            if_exists=if_exists,  # type: ignore[arg-type]
            cache_dir=cache,
            progress=(not as_json) if progress is None else progress,
        )
    report = scene.build_report
    assert report is not None
    doc = report.to_json()
    if as_json:
        echo_json(doc)
        return
    click.echo(
        f"stored scene {doc['scene_id']!r}: {doc['entities']} entities, "
        f"{doc['relations']} relations from {doc['gaussians']} Gaussians, {doc['views']} views, "
        f"{doc['masks']} masks"
    )
    for stage in doc["stages"]:
        tag = " (cached)" if stage["cached"] else ""
        click.echo(f"  {stage['name']:<10} {stage['seconds']:8.2f} s{tag}")
    click.echo(f"  peak memory {doc['peak_rss_mib']:.0f} MiB")
    for warning in doc["warnings"]:
        click.echo(f"causalsplat: warning: {warning}", err=True)
    q = doc["quality"]
    if q is not None:
        click.echo(
            f"  instance quality vs gt/gt_labels.npy: mean best IoU {q['mean_best_iou']:.3f}, "
            f"AP50 {q['ap50']:.3f} over {q['n_gt']} GT instances; {panoptic_line(q)}"
        )
