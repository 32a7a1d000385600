"""Scale benchmark: time and peak memory of each build stage against scene size.

Scenes: the synthetic ``medium`` room (60 objects) regenerated at a ladder of sizes: the
Gaussian count at fixed views and resolution, then views x pixels at a fixed Gaussian
count (``--quick``: a small ladder for a smoke run; ``CAUSALSPLAT_BENCH_SCALE=full`` adds
the 0.5 M / 1.5 M-Gaussian, 50 / 200-view, 500x375 / 1000x750 rungs, hours on 2 cores).
Each build is ``causalsplat build --json --no-cache`` in a fresh process, so the stage
times and the peak RSS (``VmHWM``) are the build's own. Growth exponents are least-squares
slopes of log(seconds) and log(peak MiB above the interpreter's) against log(size) along
each ladder. Knobs, at one rung, against the default build in the same run: where the
views' weights stay (``--views memory``, the path before out-of-core views; ``disk``;
``recompute``) and ``--image-scale 0.5``; error = 1 - mean best IoU against the GT.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from causalsplat.bench import BenchReport

NAME = "scale"
STAGES = ("load", "rasterize", "field", "instances", "graph")
SCANNET = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "scannet_scene0000_00"


def _scannet(work: Path, views: int, width: int, height: int, copies: int) -> Path | None:
    """scene0000_00 prepared at ``views`` x ``width`` x ``height`` (the real posed frames
    among them), each Gaussian copied ``copies`` times with jitter (``None`` without data)."""
    if not SCANNET.is_dir():
        return None
    folder = work / f"scannet-v{views}-{width}x{height}"
    if not folder.exists():
        argv = [sys.executable, "-m", "causalsplat", "prepare-scannet", str(SCANNET), "-o",
                str(folder), "--width", str(width), "--height", str(height),
                "--walk-views", str(max(1, views - 3))]  # fmt: skip
        subprocess.run(argv, capture_output=True, text=True, check=True)
    if copies == 1:
        return folder
    from causalsplat.bench._densify import densify_folder

    dense = work / f"{folder.name}-x{copies}"
    if not dense.exists():
        densify_folder(folder, dense, copies, jitter=0.5)
    return dense


def _scene(work: Path, gaussians: int, views: int, width: int, height: int) -> Path:
    from causalsplat.synth.config import SynthConfig
    from causalsplat.synth.generate import generate_scene
    from causalsplat.synth.write import write_synth_scene

    folder = work / f"g{gaussians}-v{views}-{width}x{height}"
    if not folder.exists():
        config = SynthConfig.preset(
            "medium", seed=0, n_gaussians=gaussians, n_views=views, width=width, height=height
        )
        write_synth_scene(generate_scene(config), folder)
    return folder


def _build(folder: Path, work: Path, *extra: str) -> dict[str, Any]:
    db = f"sqlite:///{work / 'scale.db'}"
    argv = [sys.executable, "-m", "causalsplat", "build", str(folder), "--json", "--no-cache",
            "--if-exists", "replace", "--db", db, *extra]  # fmt: skip
    proc = subprocess.run(argv, capture_output=True, text=True, check=False,
                          env={**os.environ, "PYTHONWARNINGS": "ignore"})  # fmt: skip
    if proc.returncode != 0:
        tail = proc.stderr.strip().splitlines()[-1:] or ["no message"]
        return {"error": tail[0]}
    doc: dict[str, Any] = json.loads(proc.stdout)
    return doc


def _row(label: str, size: dict[str, int], doc: dict[str, Any]) -> dict[str, Any]:
    if "error" in doc:
        return {"label": label, **size, "error": doc["error"]}
    stages = {s["name"]: s for s in doc["stages"]}
    return {
        "label": label,
        **size,
        "seconds": {k: stages[k]["seconds"] for k in STAGES if k in stages},
        "peak_mib": {k: stages[k]["peak_rss_mib"] for k in STAGES if k in stages},
        "total_s": doc["total_seconds"],
        "peak_rss_mib": doc["peak_rss_mib"],
        "iou": (doc["quality"] or {}).get("mean_best_iou"),
        "entities": doc["entities"],
    }


Rung = tuple[int, int, int, int]  # gaussians, views, width, height


def _ladders(quick: bool) -> tuple[list[Rung], list[Rung]]:
    """(Gaussian ladder, views x pixels ladder) as (gaussians, views, width, height)."""
    if quick:
        return [(10_000, 8, 160, 120), (20_000, 8, 160, 120)], [
            (10_000, 8, 160, 120), (10_000, 16, 160, 120), (10_000, 16, 320, 240),
        ]  # fmt: skip
    gaussians = [(g, 24, 320, 240) for g in (50_000, 100_000, 200_000, 400_000)]
    pixels = [(100_000, v, w, h) for v, w, h in
              ((12, 320, 240), (24, 320, 240), (48, 320, 240), (24, 640, 480))]  # fmt: skip
    if os.environ.get("CAUSALSPLAT_BENCH_SCALE") == "full":
        gaussians += [(500_000, 50, 500, 375), (1_500_000, 50, 500, 375)]
        pixels += [(1_500_000, 200, 500, 375), (1_500_000, 200, 1000, 750)]
    return gaussians, pixels


def _exponent(xs: list[float], ys: list[float]) -> float | None:
    pts = [(x, y) for x, y in zip(xs, ys, strict=True) if x > 0 and y is not None and y > 0]
    if len(pts) < 2 or len({x for x, _ in pts}) < 2:
        return None
    lx, ly = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
    return float(np.polyfit(lx, ly, 1)[0])


def _table(rows: list[dict[str, Any]], base_mib: float) -> list[str]:
    out = [
        "| build | Gaussians | views | pixels/view | " + " | ".join(f"{s} s" for s in STAGES)
        + " | total s | peak MiB | mean best IoU |",
        "|---|---|---|---|" + "---|" * len(STAGES) + "---|---|---|",
    ]  # fmt: skip
    for r in rows:
        size = f"| {r['label']} | {r['gaussians']:,} | {r['views']} | {r['width']}x{r['height']} |"
        if "error" in r:
            out.append(f"{size} failed: {r['error']} |")
            continue
        secs = " | ".join(f"{r['seconds'].get(s, 0):.1f}" for s in STAGES)
        iou = "-" if r["iou"] is None else f"{r['iou']:.3f}"
        out.append(f"{size} {secs} | {r['total_s']:.1f} | {r['peak_rss_mib']:.0f} | {iou} |")
    return out


def _growth(rows: list[dict[str, Any]], key: str, base_mib: float) -> dict[str, float | None]:
    ok = [r for r in rows if "error" not in r]
    xs = [float(r[key]) for r in ok]
    out: dict[str, float | None] = {}
    for stage in STAGES:
        out[f"{stage} time"] = _exponent(xs, [r["seconds"].get(stage) for r in ok])
    out["peak memory"] = _exponent(xs, [r["peak_rss_mib"] - base_mib for r in ok])
    return out


def _ratio_lines(rows: list[dict[str, Any]]) -> list[str]:
    """One line per row after the first: its time and peak against the first row's."""
    if len(rows) < 2 or "error" in rows[0]:
        return []
    default, out = rows[0], [""]
    for r in rows[1:]:
        if "error" in r:
            continue
        err = "-" if r["iou"] is None or default["iou"] is None else (
            f"{1 - r['iou']:.3f} vs {1 - default['iou']:.3f}"
        )  # fmt: skip
        out.append(
            f"- {r['label']}: {r['total_s'] / default['total_s']:.2f}x the time of "
            f"{default['label']}, peak {r['peak_rss_mib']:.0f} vs "
            f"{default['peak_rss_mib']:.0f} MiB, error (1 - mean best IoU) {err}."
        )
    return out


def _interpreter_mib() -> float:
    code = "import causalsplat.build, numba; from causalsplat.build.pipeline import _peak_rss_mib;"
    code += " print(_peak_rss_mib())"
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return float(proc.stdout.strip())


def _scannet_rows(work: Path, quick: bool) -> list[dict[str, Any]]:
    """scene0000_00 as the build benchmark prepares it (63 views, 320x240): the default
    build against the path before out-of-core views and the compiled rasterizer (numpy
    rasterizer, every view in memory), in the same run; with ``full``, densified x18 at 200
    views of 1000x750 too."""
    rows: list[dict[str, Any]] = []
    folder = None if quick else _scannet(work, 63, 320, 240, 1)
    if folder is None:
        return rows
    size = {"gaussians": 81_369, "views": 63, "width": 320, "height": 240,
            "view_pixels": 63 * 320 * 240}  # fmt: skip
    numpy_config = work / "numpy-raster.json"
    numpy_config.write_text(json.dumps({"raster": {"backend": "numpy"}}))
    rows.append(_row("scene0000_00, default", size, _build(folder, work)))
    before = ("--views", "memory", "--config", str(numpy_config))
    rows.append(_row("scene0000_00, numpy rasterizer, all views in memory", size,
                     _build(folder, work, *before)))  # fmt: skip
    if os.environ.get("CAUSALSPLAT_BENCH_SCALE") == "full":
        dense = _scannet(work, 200, 1000, 750, 18)
        assert dense is not None
        size = {"gaussians": 81_369 * 18, "views": 200, "width": 1000, "height": 750,
                "view_pixels": 200 * 1000 * 750}  # fmt: skip
        rows.append(_row("scene0000_00 x18, 200 views, 1000x750", size, _build(dense, work)))
        rows.append(_row("the same at --image-scale 0.5", size,
                         _build(dense, work, "--image-scale", "0.5")))  # fmt: skip
    return rows


def run(*, quick: bool = False) -> BenchReport:
    base_mib = _interpreter_mib()
    gauss_ladder, pixel_ladder = _ladders(quick)
    with tempfile.TemporaryDirectory(prefix="cs-bench-scale-") as tmp:
        work = Path(tmp)
        g_rows, p_rows = [], []
        for g, v, w, h in gauss_ladder:
            size = {"gaussians": g, "views": v, "width": w, "height": h, "view_pixels": v * w * h}
            g_rows.append(_row("default", size, _build(_scene(work, g, v, w, h), work)))
        for g, v, w, h in pixel_ladder:
            size = {"gaussians": g, "views": v, "width": w, "height": h, "view_pixels": v * w * h}
            p_rows.append(_row("default", size, _build(_scene(work, g, v, w, h), work)))
        scannet_rows = _scannet_rows(work, quick)
        g, v, w, h = pixel_ladder[-1]
        folder = _scene(work, g, v, w, h)
        size = {"gaussians": g, "views": v, "width": w, "height": h, "view_pixels": v * w * h}
        knobs = [_row("default (views auto)", size, _build(folder, work))]
        for label, extra in (
            ("--views memory (all resident)", ("--views", "memory")),
            ("--views disk --memory-budget 0", ("--views", "disk", "--memory-budget", "0")),
            ("--views recompute", ("--views", "recompute")),
            ("--image-scale 0.5", ("--image-scale", "0.5")),
        ):
            knobs.append(_row(label, size, _build(folder, work, *extra)))
    g_growth = _growth(g_rows, "gaussians", base_mib)
    p_growth = _growth(p_rows, "view_pixels", base_mib)

    def fmt(x: float | None) -> str:
        return "-" if x is None else f"{x:.2f}"

    md = [
        "Synthetic `medium` room (60 objects, SAM-like mask noise) regenerated at each size; "
        "each build `causalsplat build --json --no-cache` in its own process (stage times and "
        "peak RSS its own; the interpreter with the build's modules imported peaks at "
        f"{base_mib:.0f} MiB, subtracted before fitting memory exponents).",
        "",
        "### Growth with the number of Gaussians",
        "",
        *_table(g_rows, base_mib),
        "",
        "### Growth with views x pixels",
        "",
        *_table(p_rows, base_mib),
        "",
        "### Growth exponents (slope of log cost against log size)",
        "",
        "| cost | against Gaussians | against views x pixels |",
        "|---|---|---|",
        *(f"| {k} | {fmt(g_growth[k])} | {fmt(p_growth[k])} |" for k in g_growth),
        "",
        "### ScanNet scene0000_00 (same run)",
        "",
        *(_table(scannet_rows, base_mib) if scannet_rows else ["(skipped: no data)"]),
        *_ratio_lines(scannet_rows),
        "",
        "### Knobs at the largest views x pixels rung (same run; ratios to the default)",
        "",
        *_table(knobs, base_mib),
    ]
    md += _ratio_lines(knobs)
    data = {"scannet": scannet_rows, "gaussians": g_rows, "pixels": p_rows, "knobs": knobs,
            "base_mib": base_mib,
            "growth": {"gaussians": g_growth, "view_pixels": p_growth}}  # fmt: skip
    return BenchReport(NAME, "Scale: build time and memory against scene size", "\n".join(md),
                       data)  # fmt: skip
