"""Edge benchmark: KD-tree candidates against brute force, and validation on real data.

1. Random multi-room scenes (:mod:`causalsplat.bench._edges_scenes`) of 100, 1k and 10k
   entities: :func:`~causalsplat.graph.build_relations` (KD-tree candidates, vectorised
   rules) against two baselines run in the same process on the same scene: the plain
   reference :func:`~causalsplat.graph.build_relations_bruteforce` (a scalar loop over
   every pair) and the vectorised rules on every pair (``candidates="all"``). The
   outputs are compared for equality (same relations, bit-identical evidence): the
   "error" column counts relations that differ.
2. ScanNet object tables of the 1,513 scans of ``referit3d_scannet_objects`` against the
   Sr3D labels (:mod:`causalsplat.bench._edges_sr3d`): the share of support and vertical
   referrals whose relation is one of our edges, train and test split apart, for the
   paper's defaults and for the config tuned on train rows; closest/farthest rows
   against centroid distance; agreement with Sr3D's own box criteria over all pairs;
   build time per scan.
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable
from typing import Any

from causalsplat.bench import BenchReport
from causalsplat.bench._edges_scenes import random_rooms
from causalsplat.bench._edges_sr3d import (
    DATA,
    SPLITS,
    all_scans,
    build_scans,
    geometry_agreement,
    read_rows,
    score_horizontal,
    score_vertical,
)
from causalsplat.graph import EdgeConfig, build_relations, build_relations_bruteforce
from causalsplat.graph._edge_candidates import box_pairs, near_pairs, vertical_pairs
from causalsplat.graph._edge_scene import prepare_scene
from causalsplat.graph.edges import _kdtree_batches
from graph_store import Relation

NAME = "edges"
Relations = tuple[Relation, ...]
FULL_SIZES = (100, 1_000, 10_000)
QUICK_SIZES = (100, 1_000)
QUICK_SCANS = 100
CONFIGS: tuple[tuple[str, EdgeConfig], ...] = (
    ("paper defaults (a = 0.55)", EdgeConfig()),
    ("tuned on train (a = 0.8)", EdgeConfig.tuned_for_scannet()),
)


def _timed(fn: Callable[[], Relations], repeat: int) -> tuple[float, Relations]:
    """Best wall time of ``repeat`` calls, and the last result."""
    times, result = [], None
    for _ in range(max(repeat, 1)):
        start = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - start)
    assert result is not None
    return min(times), result


def _differences(a: Relations, b: Relations) -> int:
    return len(set(a).symmetric_difference(b))


def measure_size(n: int, *, seed: int = 0) -> dict[str, Any]:
    """Time the three builders on one random scene and compare their outputs."""
    entities = random_rooms(n, seed=seed)
    config = EdgeConfig()
    scene = prepare_scene(entities, config, "z")
    candidates = sum(len(f(scene, config)[0]) for f in (near_pairs, vertical_pairs, box_pairs))
    repeat = 3 if n <= 1_000 else 1
    kd_s, kd = _timed(lambda: build_relations(entities, config), repeat)
    start = time.perf_counter()
    batches = _kdtree_batches(prepare_scene(entities, config, "z"), config)
    rules_s = time.perf_counter() - start
    all_s, every = _timed(lambda: build_relations(entities, config, candidates="all"), 1)
    ref_s, ref = _timed(lambda: build_relations_bruteforce(entities, config), 1)
    return {
        "entities": n,
        "relations": len(kd),
        "pairs": n * (n - 1) // 2,
        "candidates": candidates,
        "kdtree_s": kd_s,
        "kdtree_rules_s": rules_s,
        "found": sum(len(b) for b in batches),
        "all_pairs_s": all_s,
        "reference_s": ref_s,
        "differ_all_pairs": _differences(kd, every),
        "differ_reference": _differences(kd, ref),
    }


def validate(*, quick: bool) -> dict[str, Any]:
    """Sr3D agreement on the ScanNet object tables (all scans, or 100 when quick)."""
    kinds = ("support", "vertical")
    rows = [r for split in SPLITS for r in read_rows(split, kinds)]
    horizontal = read_rows("test", ("horizontal",))
    scans = all_scans()
    if quick:
        labelled = sorted({r.scan for r in rows})
        scans = labelled[:QUICK_SCANS]
    out: dict[str, Any] = {"scans": len(scans), "configs": []}
    for label, config in CONFIGS:
        built = build_scans(scans, config)
        times = [b.build_s for b in built.values()]
        per_type: dict[str, float] = {}
        for scan in built.values():
            for _, kind, _ in scan.edges:
                per_type[kind] = per_type.get(kind, 0) + 1
        out["configs"].append(
            {
                "label": label,
                "config": config.to_dict(),
                "vertical": score_vertical(rows, built),
                "geometry": geometry_agreement(built),
                "mean_s": statistics.fmean(times),
                "median_s": statistics.median(times),
                "max_s": max(times),
                "entities_per_scan": statistics.fmean(len(b.entities) for b in built.values()),
                "edges_per_scan": {k: v / len(built) for k, v in sorted(per_type.items())},
            }
        )
        if "horizontal" not in out:
            out["horizontal"] = score_horizontal(horizontal, built)
    return out


def run(*, quick: bool = False) -> BenchReport:
    timing = [measure_size(n) for n in (QUICK_SIZES if quick else FULL_SIZES)]
    validation = validate(quick=quick) if DATA.exists() else None
    from causalsplat.bench._edges_report import markdown

    return BenchReport(
        NAME,
        "Scene-graph edges: KD-tree vs brute force, Sr3D validation",
        markdown(timing, validation),
        {"timing": timing, "validation": validation},
    )
