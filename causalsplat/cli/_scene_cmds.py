"""Scene-folder commands: ``synth`` (procedural rooms) and ``prepare-scannet`` (a real scan)."""

from __future__ import annotations

from pathlib import Path

import click

from causalsplat.cli._app import cli, echo_json, json_option

_SIZES = ("tiny", "small", "medium")


def _print_summary(summary: object, as_json: bool) -> None:
    from causalsplat.synth.write import SceneSummary

    assert isinstance(summary, SceneSummary)
    if as_json:
        echo_json(summary.to_json())
        return
    by_type = ", ".join(f"{k} {v}" for k, v in summary.queries_by_type.items())
    click.echo(f"scene {summary.scene_id} written to {summary.path}")
    click.echo(f"  gaussians  {summary.n_gaussians}")
    click.echo(f"  views      {summary.n_views}")
    click.echo(f"  entities   {summary.n_entities}")
    click.echo(f"  masks      {summary.n_masks} (GT {summary.n_gt_masks})")
    click.echo(f"  queries    {summary.n_queries} ({by_type})")


@cli.command("synth")
@click.option(
    "--size",
    metavar="|".join(_SIZES),
    default="tiny",
    show_default=True,
    help="tiny (CI, seconds), small (demo), medium (benchmarks).",
)
@click.option(
    "--seed", type=int, default=0, show_default=True,
    help="Random seed (the same seed writes the same bytes).",
)  # fmt: skip
@click.option(
    "-o",
    "--output",
    "out_dir",
    type=click.Path(file_okay=False, path_type=Path),
    required=True,
    help="Scene folder to create (must be absent or empty).",
)
@click.option(
    "--noise",
    "noise",
    type=float,
    default=None,
    help="Strength of the SAM-like mask noise (0 = exact GT masks; default 1).",
)
@click.option("--overwrite", is_flag=True, help="Replace an existing scene folder at OUTPUT.")
@json_option
def synth_cmd(
    size: str, seed: int, out_dir: Path, noise: float | None, overwrite: bool, as_json: bool
) -> None:
    """Write a procedural synthetic scene folder (layout: docs/formats.md).

    The folder holds a 3DGS PLY with each Gaussian's GT instance (gt_instance), COLMAP
    cameras, rendered images, noisy masks, GT masks and labels under gt/, objects.json and
    queries.json with queries of all four reasoning levels. The same seed always writes the
    same bytes.
    """
    from causalsplat.synth.write import synth_scene

    summary = synth_scene(size, seed, out_dir, noise_strength=noise, overwrite=overwrite)
    _print_summary(summary, as_json)


@cli.command("prepare-scannet")
@click.argument("src", type=click.Path(path_type=Path))
@click.option(
    "-o",
    "--output",
    "out_dir",
    type=click.Path(file_okay=False, path_type=Path),
    required=True,
    help="Scene folder to create (must be absent or empty).",
)
@click.option("--width", type=int, default=320, show_default=True, help="Image width, pixels.")
@click.option("--height", type=int, default=240, show_default=True, help="Image height, pixels.")
@click.option(
    "--walk-views",
    "walk_views",
    type=int,
    default=60,
    show_default=True,
    help="Number of generated walk-through views (the real posed frames are added).",
)
@click.option(
    "--noise",
    type=float,
    default=1.0,
    show_default=True,
    help="Strength of the SAM-like mask noise (0 = exact GT masks).",
)
@click.option("--overwrite", is_flag=True, help="Replace an existing scene folder at OUTPUT.")
@json_option
def prepare_scannet_cmd(
    src: Path,
    out_dir: Path,
    width: int,
    height: int,
    walk_views: int,
    noise: float,
    overwrite: bool,
    as_json: bool,
) -> None:
    """Turn a ScanNet scan folder SRC into a scene folder (layout: docs/formats.md).

    SRC holds the scan's mesh vertices and instance labels (mmdet3d_votenet_format/), its
    object table and utterances (language_gt/) and posed colour frames
    (mmdet3d_posed_images/); ScanNet v2 is for non-commercial research use and is never
    redistributed. One Gaussian per mesh vertex, walk-through and real-pose cameras,
    GT and noisy instance masks, objects.json, and queries.json from the Sr3D / Nr3D /
    ScanRefer utterances.
    """
    from causalsplat.scannet.prepare import prepare_scannet

    summary = prepare_scannet(
        src,
        out_dir,
        width=width,
        height=height,
        n_walk_views=walk_views,
        noise_strength=noise,
        overwrite=overwrite,
        progress=lambda line: click.echo(line, err=True),
    )
    _print_summary(summary, as_json)
