"""Mask commands: ``masks convert`` (masks people have into the canonical form) and
``masks generate`` (SAM or SAM 2 run here on a folder of images, from the user's checkpoint)."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TYPE_CHECKING

import click

from causalsplat.cli._app import cli, echo_json, fail, json_option

if TYPE_CHECKING:
    from causalsplat.masks.generate import ImageDone


@cli.group("masks")
def masks() -> None:
    """Masks people have (SAM / SAM 2 JSON, label maps, uint8 stacks) in the canonical form,
    and SAM / SAM 2 run on images from a checkpoint you have."""


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
    from causalsplat.masks.convert import MAX_SIDE, convert_masks

    if scene_folder is not None and size is not None:
        fail("give --scene FOLDER or --size WxH, not both")
    fixed = None
    if size is not None:
        w, sep, h = size.lower().partition("x")
        if not (
            sep
            and w.isdigit()
            and h.isdigit()
            and min(int(w), int(h)) > 0
            and max(int(w), int(h)) <= MAX_SIDE
        ):
            fail(f"--size must be WIDTHxHEIGHT in pixels, each in [1, {MAX_SIDE}], got {size!r}")
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


def _show_progress(done: ImageDone) -> None:
    click.echo(f"masks generate: {done.index}/{done.total} {Path(done.image).name}:"
               f" {done.masks} masks ({done.seconds:.1f} s)", err=True)  # fmt: skip
    sys.stderr.flush()


@masks.command("generate")
@click.argument("images", type=click.Path(file_okay=False, path_type=Path))
@click.option("-o", "--output", type=click.Path(file_okay=False, path_type=Path), required=True,
              help="Folder to write <image stem>.json into (SAM's JSON, COCO RLE).")  # fmt: skip
@click.option("--checkpoint", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="The model's weights file (yours: nothing is downloaded).")  # fmt: skip
@click.option("--model", default="vit_b", show_default=True,
              help="The checkpoint's architecture: vit_b, vit_l, vit_h (SAM) or"
                   " sam2.1_hiera_t|s|b+|l, sam2_hiera_t|s|b+|l (SAM 2).")  # fmt: skip
@click.option("--points-per-side", type=int, default=None,
              help="Prompt grid points per side (default 32).")  # fmt: skip
@click.option("--points-per-batch", type=int, default=None,
              help="Prompts decoded at once (default 64).")  # fmt: skip
@click.option("--pred-iou-thresh", type=float, default=None,
              help="Drop masks of lower predicted IoU, in [0, 1] (default 0.88).")  # fmt: skip
@click.option("--stability-score-thresh", type=float, default=None,
              help="Drop less stable masks, in [0, 1] (default 0.95).")  # fmt: skip
@click.option(
    "--box-nms-thresh",
    type=float,
    default=None,
    help="Box IoU above which the weaker mask is dropped, in [0, 1] (default 0.7).",
)
@click.option("--crop-n-layers", type=int, default=None,
              help="Also segment 2^k x 2^k crops for k = 1..N (default 0).")  # fmt: skip
@click.option(
    "--min-mask-region-area",
    type=int,
    default=None,
    help="Remove holes and islands below this many pixels; needs OpenCV (default 0).",
)
@click.option("--device", default="cpu", show_default=True, help="torch device to run on.")
@json_option
def generate(
    images: Path, output: Path, checkpoint: Path, model: str, device: str, as_json: bool,
    **options: int | float | None,
) -> None:  # fmt: skip
    """Run SAM's (or SAM 2's) automatic mask generator on every .png/.jpg of IMAGES and write
    OUTPUT/<stem>.json as SAM's amg.py --convert-to-rle does, for `masks convert`. One line
    per image goes to stderr."""
    from causalsplat.masks.generate import GenerateConfig, generate_masks

    config = GenerateConfig(**{k: v for k, v in options.items() if v is not None})
    report = generate_masks(images, output, checkpoint, model=model, config=config,
                            device=device, progress=_show_progress)  # fmt: skip
    if as_json:
        echo_json(report.to_json())
        return
    click.echo(f"wrote {report.views} views ({report.masks} masks, {report.model} on"
               f" {report.device}, {report.seconds:.1f} s) to {report.output}")  # fmt: skip
