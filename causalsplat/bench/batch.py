"""Batch benchmark: scenes per hour of ``build-many`` against a sequential loop of builds.

Twelve synthetic ``small`` rooms (seeds 0-11; one build takes a few seconds on 2 cores)
and twelve ``medium`` ones (about 8 s each) are each built four ways, each into a fresh
SQLite store with no stage cache: the baseline is a loop of ``Store.build`` in one fresh
process (what a user without a batch command runs: each build with the default threads,
every core), then ``build_many`` with 1, 2 and 4 workers (threads and memory budget shared
out between them). Throughput is built scenes per hour of wall time, with its ratio to
the loop's; peak memory is the largest per-scene peak (RSS of the worker during that
scene). The error column counts the scenes whose stored graph differs from the loop's
(entities by category and Gaussian count, relation types): a batch must store what the
builds store. ``--quick``: 2 tiny rooms at 40 training steps, the loop and 2 workers, as
a smoke run.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from collections import Counter
from pathlib import Path
from typing import Any

from causalsplat.bench import BenchReport

NAME = "batch"

#: The baseline: a loop of builds in one process, timed there.
_LOOP = """
import json, sys, time
from causalsplat import open_store
from causalsplat.build import BuildConfig
from causalsplat.build.pipeline import _peak_rss_mib
config = BuildConfig.from_file(sys.argv[2])
start = time.perf_counter()
with open_store(sys.argv[1]) as store:
    for folder in sys.argv[3:]:
        store.build(folder, config=config, cache_dir=False)
print(json.dumps({"seconds": time.perf_counter() - start, "peak_rss_mib": _peak_rss_mib()}))
"""

#: One scene built warm on two threads and on one, in a fresh process: what the loop's
#: builds gain from the second core bounds what single-thread workers can gain over it.
_THREADS = """
import dataclasses, json, sys, time
from causalsplat.build import BuildConfig
from causalsplat.build.pipeline import build_scene
config = BuildConfig.from_file(sys.argv[1])
seconds = {}
for threads in (2, 2, 1, 2, 1):  # the first build warms the process up
    raster = dataclasses.replace(config.raster, threads=threads)
    start = time.perf_counter()
    build_scene(sys.argv[2], config=dataclasses.replace(config, raster=raster), cache_dir=False)
    seconds.setdefault(threads, []).append(time.perf_counter() - start)
print(json.dumps({str(t): min(v[1:] if t == 2 else v) for t, v in seconds.items()}))
"""


def _scenes(work: Path, size: str, n: int) -> list[Path]:
    from causalsplat.synth import synth_scene

    folders = [work / f"{size}{seed}" for seed in range(n)]
    for seed, folder in enumerate(folders):
        synth_scene(size, seed, folder)
    return folders


def _signatures(url: str) -> dict[str, tuple[Any, ...]]:
    """Per stored scene: its entities (category, Gaussian count) and relation types."""
    from graph_store import open_store

    out = {}
    with open_store(url, create=False) as store:
        for summary in store.list_scenes():
            g = store.load_scene(summary.scene_id)
            ents = tuple(sorted((e.category, e.point_count) for e in g.entities))
            rels = tuple(sorted(Counter(r.type.value for r in g.relations).items()))
            out[summary.scene_id] = (ents, rels)
    return out


def _loop(work: Path, folders: list[Path], config: Path) -> dict[str, Any]:
    url = f"sqlite:///{work / 'loop.db'}"
    argv = [sys.executable, "-c", _LOOP, url, str(config), *map(str, folders)]
    proc = subprocess.run(argv, capture_output=True, text=True, check=False,
                          env={**os.environ, "PYTHONWARNINGS": "ignore"})  # fmt: skip
    if proc.returncode != 0:
        tail = proc.stderr.strip().splitlines()[-1:] or ["no message"]
        return {"label": "sequential loop of build", "error": tail[0]}
    doc = json.loads(proc.stdout)
    return {"label": "sequential loop of build", "workers": 1, "built": len(folders),
            "failed": 0, "url": url, **doc}  # fmt: skip


def _one_scene(folder: Path, config: Path) -> dict[str, float]:
    """Seconds of one warm build of ``folder`` on 2 threads and on 1 (best of two each)."""
    argv = [sys.executable, "-c", _THREADS, str(config), str(folder)]
    proc = subprocess.run(argv, capture_output=True, text=True, check=False,
                          env={**os.environ, "PYTHONWARNINGS": "ignore"})  # fmt: skip
    if proc.returncode != 0:
        return {}
    return {f"threads_{k}": v for k, v in json.loads(proc.stdout).items()}


def _batch(work: Path, folders: list[Path], config: Path, workers: int) -> dict[str, Any]:
    from causalsplat.build import BuildConfig
    from causalsplat.build.batch import build_many

    url = f"sqlite:///{work / f'batch{workers}.db'}"
    report = build_many(folders, url, workers=workers, config=BuildConfig.from_file(config),
                        cache_dir=False)  # fmt: skip
    s = report.summary_json()
    return {"label": f"build-many --workers {workers}", "workers": workers, "url": url,
            "built": s["built"], "failed": s["failed"], "seconds": s["seconds"],
            "peak_rss_mib": s["peak_rss_mib"]}  # fmt: skip


def run(*, quick: bool = False) -> BenchReport:
    plans = [("tiny", 2, 40)] if quick else [("small", 12, None), ("medium", 12, None)]
    counts = (2,) if quick else (1, 2, 4)
    load_before = os.getloadavg()
    tables: list[tuple[str, int, list[dict[str, Any]]]] = []
    for size, n, iterations in plans:
        tables.append((size, n, _runs(size, n, iterations, counts)))
    load_after = os.getloadavg()
    md = [
        "Synthetic rooms (seeds 0-11 of each size), each run into a fresh SQLite store "
        "without the stage cache; the loop is `Store.build` over the folders in one fresh "
        "process (default threads: every core); `build-many` splits the threads and the "
        f"memory budget between its workers. Machine: {os.cpu_count()} CPU cores; load "
        f"average {load_before[0]:.1f} before the run and {load_after[0]:.1f} after it (other "
        "jobs on the same cores distort absolute times; the ratios were measured in one run).",
    ]
    for size, n, rows in tables:
        md += _table(size, n, rows)
    md += [
        "",
        "Peak memory: the loop's is its process's; a batch's is the largest of its scenes "
        "(one worker's RSS during that scene), so a batch of W workers holds up to W times it.",
        "Each worker process pays its own imports and start (a few seconds), which weighs",
        "more the shorter the builds are.",
    ]
    data = {"tables": [{"size": s, "scenes": n, "rows": r} for s, n, r in tables],
            "load": [load_before, load_after]}  # fmt: skip
    return BenchReport(NAME, "Batch builds: build-many against a sequential loop",
                       "\n".join(md), data)  # fmt: skip


def _runs(
    size: str, n: int, iterations: int | None, counts: tuple[int, ...]
) -> list[dict[str, Any]]:
    """The loop and a batch per worker count over ``n`` rooms of ``size``."""
    with tempfile.TemporaryDirectory(prefix="cs-bench-batch-") as tmp:
        work = Path(tmp)
        folders = _scenes(work, size, n)
        config = work / "config.json"
        config.write_text(json.dumps({} if iterations is None else
                                     {"field": {"iterations": iterations}}))  # fmt: skip
        rows = [_loop(work, folders, config)]
        rows += [_batch(work, folders, config, w) for w in counts]
        rows[0].update(_one_scene(folders[0], config))
        reference = _signatures(rows[0]["url"]) if "error" not in rows[0] else {}
        for row in rows:
            if "error" in row:
                continue
            got = _signatures(row.pop("url"))
            row["differing"] = sum(got.get(k) != v for k, v in reference.items())
            row["scenes_per_hour"] = 3600.0 * row["built"] / row["seconds"]
    return rows


def _table(size: str, n: int, rows: list[dict[str, Any]]) -> list[str]:
    base = rows[0].get("scenes_per_hour")
    md = [
        "",
        f"{n} `{size}` rooms:",
        "",
        "| run | wall s | scenes/hour | vs the loop | peak MiB per scene | failed | "
        "graphs differing from the loop's (error) |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        if "error" in r:
            md.append(f"| {r['label']} | failed: {r['error']} | | | | | |")
            continue
        ratio = "-" if not base else f"{r['scenes_per_hour'] / base:.2f}x"
        md.append(
            f"| {r['label']} | {r['seconds']:.1f} | {r['scenes_per_hour']:.1f} | {ratio} | "
            f"{r['peak_rss_mib']:.0f} | {r['failed']} | {r['differing']} of {n} |"
        )
    two, one = rows[0].get("threads_2"), rows[0].get("threads_1")
    if two and one:
        md += [
            "",
            f"One of these scenes alone, warm: {two:.2f} s on two threads (as each build of the "
            f"loop), {one:.2f} s on one (as in each of two workers). Two single-thread workers "
            f"are therefore bounded at 2 x {two:.2f} / {one:.2f} = **{2 * two / one:.2f}x** the "
            "loop, before their start, their first scene's warm-up and the two processes "
            "sharing the memory bus.",
        ]
    return md
