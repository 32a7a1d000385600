"""Query benchmark: latency of the three executors on 1-, 4- and 8-step programs.

Scenes of 100, 1k, 10k and 100k entities (``quick``: 100 and 1k) at a constant density
(objects on a floor, stacks resting on each other, ``near`` edges to the 3 nearest
neighbours; about 4 relations per entity). Programs (all steps counted, the scene step
included):

* 1 step: ``scene()``;
* 4 steps: the DESIGN §6 example, towels near sinks (two category filters and a ``relate``);
* 8 steps: tables, cups on tables, the red ones, the 3 highest of them, what falls without
  them, how many (filters, ``relate``, ``filter_attribute``, ``argmax``,
  ``fall_if_removed``, ``count``).

Each executor is prepared once per scene (networkx graphs or the memory executor's dicts
built, scene saved in a SQLite
file, Oxigraph / rdflib store loaded; those one-off costs are reported apart) and then runs
each program ``repeats`` times after one warm-up run (garbage collector paused during a
run, as ``timeit`` does); p50 and p95 are over those runs. The
networkx reference is measured in the same process and every other executor is reported
as a ratio to it; the "agrees" column checks each result against the reference's (the
benchmark's error measure). PostgreSQL joins when ``CAUSALSPLAT_TEST_POSTGRES_URL`` names
a server (a scratch database is created and dropped); rdflib runs at 1k entities and below
only (pure-Python evaluation: seconds per program beyond).
"""

from __future__ import annotations

import gc
import math
import os
import statistics
import tempfile
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from causalsplat.bench import BenchReport
from causalsplat.bench._postgres import scratch_database
from graph_store.repository import open_store
from graph_store.types import Attribute, Entity, Relation, SceneGraph, SceneMeta
from queries import Executor, GraphQuery
from queries.memory_executor import MemoryExecutor
from queries.networkx_executor import NetworkxExecutor
from queries.sparql_executor import SparqlExecutor
from queries.sql_executor import SqlExecutor

NAME = "queries"
SIZES = (100, 1_000, 10_000, 100_000)
QUICK_SIZES = (100, 1_000)
CATEGORIES = ("table", "cup", "chair", "sink", "towel", "book", "lamp", "shelf", "plate", "bowl")
COLORS = ("red", "blue", "white")

PROGRAMS: dict[int, str] = {
    1: "query intrinsic\nv0 = scene()",
    4: """query spatial
v0 = scene()
v1 = filter_category(v0, "sink")
v2 = filter_category(v0, "towel")
v3 = relate(v2, v1, near)""",
    8: """query counterfactual
v0 = scene()
v1 = filter_category(v0, "table")
v2 = filter_category(v0, "cup")
v3 = relate(v2, v1, supported_by)
v4 = filter_attribute(v3, "color=red")
v5 = argmax(v4, z, k=3)
v6 = fall_if_removed(v5)
v7 = count(v6)""",
}


def synthetic_scene(n: int, *, seed: int = 0) -> SceneGraph:
    """A floor (id 0) and ``n - 1`` objects; ~1/3 of the objects rest on another object."""
    from scipy.spatial import cKDTree

    rng = np.random.default_rng(seed)
    side = 2.0 * math.sqrt(n)  # ~4 m² of floor per entity
    xy = rng.uniform(-side / 2, side / 2, size=(n, 2))
    half = rng.uniform(0.1, 0.5, size=(n, 3))
    base = np.zeros(n)
    on: list[int] = [0] * n
    for i in range(1, n):  # stack on an earlier object now and then
        if i > 3 and rng.random() < 0.35:
            j = int(rng.integers(1, i))
            xy[i] = xy[j] + rng.uniform(-0.1, 0.1, size=2)
            base[i] = base[j] + 2 * half[j, 2]
            on[i] = j
    z = base + half[:, 2]
    ents = [Entity(0, "floor", (0.0, 0.0, -0.05), (-side, -side, -0.1), (side, side, 0.0))]
    for i in range(1, n):
        c = (float(xy[i, 0]), float(xy[i, 1]), float(z[i]))
        lo = tuple(float(v) for v in (c[0] - half[i, 0], c[1] - half[i, 1], base[i]))
        hi = tuple(
            float(v) for v in (c[0] + half[i, 0], c[1] + half[i, 1], base[i] + 2 * half[i, 2])
        )
        attrs = (Attribute("color", COLORS[i % 3]),)
        ents.append(Entity(i, CATEGORIES[i % len(CATEGORIES)], c, lo, hi, str(i), attributes=attrs))
    rels = {(i, "supported_by", on[i]) for i in range(1, n)}
    if n > 4:
        _, nearest = cKDTree(xy[1:]).query(xy[1:], k=4)
        for row in nearest:
            a = int(row[0]) + 1
            rels.update((a, "near", int(b) + 1) for b in row[1:] if int(b) + 1 != a)
    relations = tuple(Relation(s, d, t) for s, t, d in sorted(rels))
    return SceneGraph(SceneMeta(f"bench-{n}", source="build"), tuple(ents), relations)


def _time(executor: Executor, program: GraphQuery, repeats: int) -> tuple[list[float], Any]:
    """Wall time of ``repeats`` runs after a warm-up, with the garbage collector paused
    during each run (as ``timeit`` does: a full collection walks every live object, and the
    scenes held in memory would make it cost more than the query)."""
    result = executor.run(program)  # warm-up
    times = []
    for _ in range(repeats):
        gc.collect()
        gc.disable()
        try:
            t0 = time.perf_counter()
            executor.run(program)
            times.append(time.perf_counter() - t0)
        finally:
            gc.enable()
    return times, result


def _p(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(q * (len(ordered) - 1)))]


def _executors(
    graph: SceneGraph, stores: dict[str, Any], n: int
) -> Iterator[tuple[str, Callable[[], Executor]]]:
    yield "networkx", lambda: NetworkxExecutor(graph)
    yield "memory", lambda: MemoryExecutor(graph)
    for name, store in stores.items():

        def sql(store: Any = store) -> Executor:
            store.save_scene(graph, if_exists="replace")
            return SqlExecutor(store.engine, graph.scene_id)

        yield f"sql-{name}", sql
    yield "sparql-oxigraph", lambda: SparqlExecutor.from_graph(graph, "oxigraph")
    if n <= 1_000:
        yield "sparql-rdflib", lambda: SparqlExecutor.from_graph(graph, "rdflib")


def _measure(sizes: tuple[int, ...], stores: dict[str, Any]) -> list[dict[str, Any]]:
    programs = {k: GraphQuery.from_text(t) for k, t in PROGRAMS.items()}
    rows: list[dict[str, Any]] = []
    for n in sizes:
        graph = synthetic_scene(n)
        repeats = 20 if n <= 1_000 else 10 if n <= 10_000 else 5
        reference: dict[int, Any] = {}
        for name, make in _executors(graph, stores, n):
            t0 = time.perf_counter()
            executor = make()
            setup = time.perf_counter() - t0
            for steps, program in programs.items():
                times, result = _time(executor, program, repeats)
                reference.setdefault(steps, result)
                rows.append(
                    {
                        "entities": n,
                        "relations": len(graph.relations),
                        "executor": name,
                        "steps": steps,
                        "p50_ms": 1e3 * statistics.median(times),
                        "p95_ms": 1e3 * _p(times, 0.95),
                        "runs": repeats,
                        "setup_s": setup,
                        "agrees": result == reference[steps],
                        "answer_size": result.step_size(program.answer_step),
                    }
                )
    return rows


def run(*, quick: bool = False) -> BenchReport:
    sizes = QUICK_SIZES if quick else SIZES
    load = os.getloadavg()
    with tempfile.TemporaryDirectory() as tmp, scratch_database() as pg_url:
        stores = {"sqlite": open_store(f"sqlite:///{Path(tmp) / 'bench.db'}")}
        if pg_url is not None:
            stores["postgres"] = open_store(pg_url)
        try:
            rows = _measure(sizes, stores)
        finally:
            for store in stores.values():
                store.close()
    from causalsplat.bench._queries_report import render

    machine = (
        f"{os.cpu_count()} CPU cores; load average {load[0]:.1f} / {load[1]:.1f} / {load[2]:.1f}"
        " (1 / 5 / 15 min) when the run started"
    )
    markdown = render(rows, sizes, machine)
    return BenchReport(NAME, "Structured queries: executor latency", markdown, {"rows": rows})
