"""Render benchmark, first part: building a view's contributors, compiled kernel vs numpy.

Per scene, with the default rules (no cap, ``T_min = 1e-4``): the build time per view of
the numba kernel (``backend="numba"``, all the cores this process may use, and one
thread) and of the numpy path (``backend="numpy"``, the numpy build the project had
before the kernel), timed in the same process in interleaved rounds; the relative L2
error of 16-channel feature renders of each against the exact composite; whether both
keep the same (pixel, Gaussian) pairs in the same order and how far their weights are
apart; the peak memory of one build (``tracemalloc``: every array of both paths is a
numpy allocation; the kernels allocate only the tile binning's cursor array).

"Exact composite": no cap and ``T_min = 0`` (every Gaussian with alpha >= 1/255 drawn),
built by the kernel and evaluated in float64; the tests hold both paths to the float64
per-pixel reference and to each other on small scenes.
"""

from __future__ import annotations

import os
import time
import tracemalloc
from collections.abc import Callable
from typing import Any

import numpy as np

from causalsplat.bench._render_scenes import BenchScene
from causalsplat.render.config import RasterConfig
from causalsplat.render.types import Contributors

CHANNELS = 16


def _builder(bench: BenchScene, config: RasterConfig) -> list[Callable[[], Contributors]]:
    from causalsplat.render.functional import build_contributors

    return [
        lambda cam=cam: build_contributors(bench.scene, cam, config=config, cache=False)
        for cam in bench.cameras
    ]


def _peak_mib(fn: Callable[[], Contributors]) -> float:
    """Peak traced memory of one call, MiB (what it allocates, its result included)."""
    tracemalloc.start()
    try:
        fn()
        return tracemalloc.get_traced_memory()[1] / 2**20
    finally:
        tracemalloc.stop()


def _best_times(
    builds: dict[str, list[Callable[[], Contributors]]], rounds: dict[str, int]
) -> tuple[dict[str, float], dict[str, float]]:
    """(wall, CPU): mean over views of the fastest build per view, in ms; rounds visit every
    path and view once (spreads the load of a shared host over all of them). CPU time is
    the process's, all its threads together."""
    wall = {name: [float("inf")] * len(fns) for name, fns in builds.items()}
    cpu = {name: [float("inf")] * len(fns) for name, fns in builds.items()}
    for r in range(max(rounds.values())):
        for name, fns in builds.items():
            if r >= rounds[name]:
                continue
            for k, fn in enumerate(fns):
                c0, t0 = time.process_time(), time.perf_counter()
                fn()
                wall[name][k] = min(wall[name][k], time.perf_counter() - t0)
                cpu[name][k] = min(cpu[name][k], time.process_time() - c0)

    def mean_ms(best: dict[str, list[float]]) -> dict[str, float]:
        return {name: 1e3 * float(np.mean(times)) for name, times in best.items()}

    return mean_ms(wall), mean_ms(cpu)


def measure_build(bench: BenchScene, *, rounds: int, numpy_rounds: int) -> dict[str, Any]:
    """Times, errors, agreement and peak memory of both paths on ``bench``'s views."""
    from causalsplat.render._kernel import available_cores

    threads = available_cores()
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    configs = {
        "numpy": RasterConfig(backend="numpy"),
        "kernel": RasterConfig(backend="numba"),
        "kernel_1": RasterConfig(backend="numba", threads=1),
    }
    builds = {name: _builder(bench, cfg) for name, cfg in configs.items()}
    feats = np.random.default_rng(0).standard_normal((bench.scene.n, CHANNELS))
    exact = [
        c().matrix(np.float64) @ feats for c in _builder(bench, RasterConfig(transmittance_min=0.0))
    ]
    norm = float(np.sqrt(sum(float((e * e).sum()) for e in exact)))
    err2 = {"numpy": 0.0, "kernel": 0.0}
    same, max_diff, nnz = True, 0.0, []
    for k, ex in enumerate(exact):
        got = {name: builds[name][k]() for name in err2}  # also the warm-up (compilation)
        for name, c in got.items():
            err2[name] += float(((c.matrix(np.float64) @ feats - ex) ** 2).sum())
        a, b = got["kernel"], got["numpy"]
        same &= np.array_equal(a.indptr, b.indptr) and np.array_equal(a.indices, b.indices)
        if same:
            diff = np.abs(a.weights.astype(np.float64) - b.weights)
            max_diff = max(max_diff, float(diff.max(initial=0.0)))
        nnz.append(a.nnz)
    builds["kernel_1"][0]()
    times, cpu = _best_times(builds, {"numpy": numpy_rounds, "kernel": rounds, "kernel_1": rounds})
    peaks = {name: _peak_mib(builds[name][0]) for name in ("numpy", "kernel")}
    return {
        "label": bench.label,
        "threads": threads,
        "load": load,
        "numpy_ms": times["numpy"],
        "kernel_ms": times["kernel"],
        "kernel_1_ms": times["kernel_1"],
        "numpy_cpu_ms": cpu["numpy"],
        "kernel_1_cpu_ms": cpu["kernel_1"],
        "numpy_error": np.sqrt(err2["numpy"]) / norm,
        "kernel_error": np.sqrt(err2["kernel"]) / norm,
        "same_pairs": bool(same),
        "max_weight_diff": max_diff,
        "nnz": float(np.mean(nnz)),
        "numpy_peak_mib": peaks["numpy"],
        "kernel_peak_mib": peaks["kernel"],
        "rounds": rounds,
        "numpy_rounds": numpy_rounds,
    }


def build_markdown(results: list[dict[str, Any]]) -> str:
    """The section's table and its ratio lines."""
    threads = results[0]["threads"]
    lines = [
        "| scene | numpy path ms/view | kernel ms/view "
        f"({threads} thread{'s' if threads > 1 else ''}) | kernel ms/view (1 thread) "
        "| speed-up | speed-up, 1 thread | CPU ms/view numpy, kernel 1 thread | CPU ratio "
        "| rel. L2 error numpy | rel. L2 error kernel | same pairs, order "
        "| max abs weight diff | weights/view | peak MiB numpy | peak MiB kernel | host load |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in results:
        lines.append(
            f"| {r['label']} | {r['numpy_ms']:.0f} | {r['kernel_ms']:.1f} "
            f"| {r['kernel_1_ms']:.1f} | {r['numpy_ms'] / r['kernel_ms']:.1f}x "
            f"| {r['numpy_ms'] / r['kernel_1_ms']:.1f}x "
            f"| {r['numpy_cpu_ms']:.0f}, {r['kernel_1_cpu_ms']:.1f} "
            f"| {r['numpy_cpu_ms'] / r['kernel_1_cpu_ms']:.1f}x | {r['numpy_error']:.3e} "
            f"| {r['kernel_error']:.3e} | {'yes' if r['same_pairs'] else 'NO'} "
            f"| {r['max_weight_diff']:.1e} | {r['nnz'] / 1e6:.2f} M | {r['numpy_peak_mib']:.0f} "
            f"| {r['kernel_peak_mib']:.0f} | {r['load']:.1f} |"
        )
    lines.append("")
    for r in results:
        ratio = r["numpy_ms"] / r["kernel_ms"]
        lines.append(
            f"- **{r['label'].split(':')[0]}: compiled kernel {ratio:.1f}x "
            f"faster per view than the numpy path** ({r['kernel_ms']:.1f} ms vs "
            f"{r['numpy_ms']:.0f} ms; goal >= 10x), error {r['kernel_error']:.3e} vs "
            f"{r['numpy_error']:.3e}; {r['numpy_ms'] / r['kernel_1_ms']:.1f}x on one thread, "
            f"{r['numpy_cpu_ms'] / r['kernel_1_cpu_ms']:.1f}x in CPU time."
        )
    return "\n".join(lines)
