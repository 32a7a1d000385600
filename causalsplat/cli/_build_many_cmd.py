"""The build-many command: many scene folders into one store, resumably."""

from __future__ import annotations

from pathlib import Path

import click

from causalsplat.cli._app import cli, db_option, echo_json, fail, json_option
from causalsplat.cli._build_cmd import build_options, config_from_options


@cli.command("build-many")
@click.argument(
    "folders", nargs=-1, required=True, type=click.Path(file_okay=False, path_type=Path)
)
@click.option(
    "--workers",
    type=click.IntRange(min=1),
    help="Scenes built at once (default: one per core, at most one per 4 GiB of RAM; with "
    "--ray: as many as the cluster's CPUs allow).",
)
@click.option(
    "--ray",
    "ray_address",
    metavar="ADDRESS",
    help="Build each scene as a task on this Ray cluster (ADDRESS of its head, 'auto' for "
    "the cluster of this machine, 'local' to start one here); needs causalsplat[ray]. "
    "Workers write to the store themselves: give a PostgreSQL --db on a multi-node cluster.",
)
@click.option(
    "--if-exists",
    type=click.Choice(["skip", "replace", "rebuild"]),
    default="skip",
    show_default=True,
    help="Stored scenes: skip those built from the same inputs and options (always); one "
    "whose inputs or options changed fails (skip) or is rebuilt (replace); rebuild rebuilds all.",
)
@click.option(
    "--retries",
    type=click.IntRange(min=0),
    default=1,
    show_default=True,
    help="Further attempts of a scene that failed in a way that may not repeat (its worker "
    "died, an unexpected error); a malformed folder is not retried.",
)
@click.option(
    "--report",
    "report_path",
    type=click.Path(dir_okay=False, path_type=Path),
    help="Write a JSON line per scene as it ends (time, peak memory, entities, error), "
    'then {"summary": ...}.',
)
@build_options
@click.option(
    "--progress/--no-progress",
    default=None,
    help="A line on stderr per scene started, built, skipped, retried or failed "
    "(default: on, off with --json).",
)
@db_option
@json_option
def build_many(
    folders: tuple[Path, ...],
    workers: int | None,
    ray_address: str | None,
    if_exists: str,
    retries: int,
    report_path: Path | None,
    config_file: Path | None,
    max_views: int | None,
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
    """Build many scene folders into one store, in parallel and resumably.

    Each folder is stored under the id `build` gives it. A scene already stored from the
    same inputs and options is skipped, so running the command again after a crash builds
    only what is missing; a worker killed mid-build loses only its scene (each scene is
    written in one transaction) and the scene is tried again. Build options apply to each
    scene. Prints a summary (built, skipped, failed, scenes per hour); exits with status 1
    when a scene failed.
    """
    from causalsplat.build.batch import build_many as build_many_scenes

    config = config_from_options(config_file, max_views, labeler, allow_distortion, image_scale,
                                 threads, memory_budget, views, device)  # fmt: skip
    show = (not as_json) if progress is None else progress

    def line(text: str) -> None:
        click.echo(f"causalsplat: {text}", err=True)

    report = build_many_scenes(
        folders,
        db_url,
        workers=workers,
        ray_address=ray_address,
        config=config,
        if_exists=if_exists,  # type: ignore[arg-type]
        retries=retries,
        cache_dir=False if no_cache else (cache_dir or True),
        report_path=report_path,
        progress=line if show else None,
    )
    if as_json:
        echo_json(report.to_json())
    else:
        s = report.summary_json()
        click.echo(
            f"{s['scenes']} scenes: {s['built']} built, {s['skipped']} skipped, "
            f"{s['failed']} failed in {s['seconds']:.1f} s ({s['scenes_per_hour']:.1f} scenes "
            f"per hour, {_workers(s['workers'], s['engine'])}, "
            f"peak {s['peak_rss_mib']:.0f} MiB per scene)"
        )
        for o in report.outcomes:
            detail = (
                f"{o.seconds:7.1f} s {o.peak_rss_mib:6.0f} MiB {o.entities:4d} entities"
                if o.status == "built"
                else (o.error or "")
            )
            click.echo(f"  {o.status:<8} {o.scene_id:<24} {detail}")
    if report.failed:
        fail(
            f"{report.failed} of {len(report.outcomes)} scenes failed"
            + (f" (see {report_path})" if report_path else "")
            + "; once fixed, the same command builds only what is missing"
        )


def _workers(n: int, engine: str) -> str:
    """How many ran at once, for the summary line.

    >>> _workers(1, "local"), _workers(4, "ray")
    ('1 worker', '4 Ray tasks at once')
    """
    if engine == "ray":
        return f"{n} Ray task{'s' if n != 1 else ''} at once"
    return f"{n} worker{'s' if n != 1 else ''}"
