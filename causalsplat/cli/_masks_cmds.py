"""Mask commands: ``masks convert`` (masks people have into the canonical form)."""

from __future__ import annotations

from pathlib import Path

import click

from causalsplat.cli._app import cli, echo_json, fail, json_option


@cli.group("masks")
def masks() -> None:
    """Masks people have (SAM / SAM 2 JSON, label maps, uint8 stacks) in the canonical form."""


@masks.command("convert")
@click.argument("source", type=click.Path(file_okay=False, path_type=Path))
@click.option("-o", "--output", type=click.Path(file_okay=False, path_type=Path),
              required=True, help="Folder to write <image stem>.npz files into.")  # fmt: skip
@click.option(
    "--scene", "scene_folder", type=click.Path(file_okay=False, path_type=Path), default=None,
    help="Resample each view's masks to its camera's size (a scene folder's cameras).",
)  # fmt: skip
@click.option("--size", default=None, metavar="WxH", help="Resample every view to WxH pixels.")
@json_option
def convert(
    source: Path, output: Path, scene_folder: Path | None, size: str | None, as_json: bool
) -> None:
    """Convert SOURCE's mask files (.json from SAM's automatic mask generator with COCO RLE
    or polygons, .png/.npy label maps, .npz/.npy mask stacks) to OUTPUT/<stem>.npz."""
    from causalsplat.build.folder import camera_sizes
    from causalsplat.masks.convert import convert_masks

    if scene_folder is not None and size is not None:
        fail("give --scene FOLDER or --size WxH, not both")
    fixed = None
    if size is not None:
        w, sep, h = size.lower().partition("x")
        if not (sep and w.isdigit() and h.isdigit() and int(w) > 0 and int(h) > 0):
            fail(f"--size must be WIDTHxHEIGHT in pixels (both > 0), got {size!r}")
        fixed = (int(h), int(w))
    sizes = camera_sizes(scene_folder) if scene_folder is not None else None
    report = convert_masks(source, output, sizes=sizes, size=fixed)
    if as_json:
        echo_json(report.to_json())
        return
    click.echo(f"wrote {report.views} views ({report.masks} masks; {report.labelled_views}"
               f" labelled, {report.resampled_views} resampled) to {report.output}")  # fmt: skip
    if report.labelled_views < report.views:
        click.echo("note: masks without labels build entities of unknown category: add labels"
                   " or build with --labeler vlm", err=True)  # fmt: skip
