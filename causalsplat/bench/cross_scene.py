"""Cross-scene benchmark: one program over every stored ScanNet scan.

The ScanNet object tables of ``../shared/data/referit3d_scannet_objects`` (1,513 scans;
see its ``SOURCE.md``; ``$CAUSALSPLAT_SCANNET_OBJECTS`` names another copy of that folder)
are turned into objects files (id, label, AABB centre and size) and stored through the
code ``causalsplat ingest-objects`` runs (:func:`causalsplat.objects.read_objects`, then
:func:`~causalsplat.objects.objects_to_scene_graph`, then ``save_scene``), in the order of
their scan ids: first 100, then up to 1,000, then all, the programs being measured at
each size over every stored scene. On SQLite (a file) and, when
``$CAUSALSPLAT_BENCH_POSTGRES_URL`` (else ``$CAUSALSPLAT_TEST_POSTGRES_URL``) gives an
admin URL, on a fresh PostgreSQL database made for the run and dropped after it.

For each program: the latency of :func:`queries.run_program_all` with the ``sql``
executor (one statement for all scenes) against the per-scene loop a user would write
without it (``run_program(store, scene, program, executor="sql")`` for each scene), in the
same process; the two answers compared scene by scene (the "differ" column: scenes whose
result, every step and support path included, is not equal); and the peak of Python
allocations of one run of each (``tracemalloc``, untimed).

SPARQL on Oxigraph, at the sizes up to :data:`SPARQL_MAX_SCENES` (the per-scene loop
sends a few queries per scan, so it is the slow side): the stored scans are loaded into
one in-memory Oxigraph store (its load time reported apart), then
:func:`queries.sparql_many.run_sparql_many` (one query per step for all scans) is timed
against the per-scene loop of :class:`~queries.sparql_executor.SparqlExecutor` on the same
store, each answer compared scene by scene as above.
"""

from __future__ import annotations

import gc
import json
import os
import statistics
import tempfile
import time
import tracemalloc
from collections.abc import Callable
from pathlib import Path
from typing import Any

from causalsplat.bench import BenchReport
from causalsplat.bench._postgres import scratch_database

NAME = "cross-scene"
DATA = Path(
    os.environ.get("CAUSALSPLAT_SCANNET_OBJECTS")
    or Path(__file__).resolve().parents[2].parent / "shared" / "data" / "referit3d_scannet_objects"
)
SIZES = (100, 1_000, 1_513)
QUICK_SIZES = (20,)
#: SPARQL (Oxigraph) rows are measured at the sizes up to this many scans (all of them:
#: loading 1,513 scans into Oxigraph takes seconds, the per-scene loop well under a second
#: per run).
SPARQL_MAX_SCENES = 1_513
GOAL_S = 1.0

#: Realistic questions over a dataset of scans (categories as ScanNet labels them).
PROGRAMS: dict[str, str] = {
    "a microwave above a toaster": """query spatial
v0 = scene()
v1 = filter_category(v0, "microwave")
v2 = filter_category(v0, "toaster")
v3 = relate(v1, v2, above)""",
    "every pillow on a bed": """query spatial
v0 = scene()
v1 = filter_category(v0, "pillow")
v2 = filter_category(v0, "bed")
v3 = relate(v1, v2, supported_by)""",
    "how many monitors rest on a desk": """query spatial
v0 = scene()
v1 = filter_category(v0, "monitor")
v2 = filter_category(v0, "desk")
v3 = relate(v1, v2, supported_by)
v4 = count(v3)""",
    "the lamp nearest a bed": """query spatial
v0 = scene()
v1 = filter_category(v0, "lamp")
v2 = filter_category(v0, "bed")
v3 = argmin(v1, v2, distance, k=1)""",
    "what falls if the tables are removed": """query counterfactual
v0 = scene()
v1 = filter_category(v0, "table")
v2 = fall_if_removed(v1)""",
}


def objects_document(scan: str, root: Path = DATA) -> dict[str, Any]:
    """The objects file (DESIGN §9) of one scan's object table: AABB centre and size."""
    path = root / "objects_info" / f"objects_info_{scan}.json"
    table = json.loads(path.read_text(encoding="utf-8"))
    objects = [
        {"id": int(o["id"]), "label": str(o["label"]), "center": o["center_position"],
         "size": o["size"]}
        for o in table
    ]  # fmt: skip
    return {"scene_id": scan, "units": "m", "up": "z", "objects": objects}


def all_scans(root: Path = DATA) -> list[str]:
    """Every scan with an object table, sorted."""
    return sorted(p.stem.removeprefix("objects_info_") for p in (root / "objects_info").iterdir())


def _ingest(stores: dict[str, Any], scans: list[str], folder: Path, root: Path) -> dict[str, float]:
    """Store ``scans`` in every store as ``ingest-objects`` does; seconds per store (the
    graph is built once per scan and its build time counted for each store)."""
    from causalsplat.objects import objects_to_scene_graph, read_objects

    spent = dict.fromkeys(stores, 0.0)
    for scan in scans:
        path = folder / f"{scan}.json"
        path.write_text(json.dumps(objects_document(scan, root)), encoding="utf-8")
        t0 = time.perf_counter()
        graph = objects_to_scene_graph(read_objects(path))
        built = time.perf_counter() - t0
        for name, store in stores.items():
            t1 = time.perf_counter()
            store.save_scene(graph)
            spent[name] += built + time.perf_counter() - t1
        path.unlink()
    return spent


def _times(fn: Callable[[], Any], repeats: int) -> tuple[list[float], Any]:
    """Wall times of ``repeats`` calls after one warm-up call (collector off while timing)."""
    result = fn()
    times = []
    gc.collect()
    gc.disable()
    try:
        for _ in range(repeats):
            t0 = time.perf_counter()
            fn()
            times.append(time.perf_counter() - t0)
    finally:
        gc.enable()
    return times, result


def _peak_mib(fn: Callable[[], Any]) -> float:
    gc.collect()
    tracemalloc.start()
    try:
        fn()
        return tracemalloc.get_traced_memory()[1] / 2**20
    finally:
        tracemalloc.stop()


def _p(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(q * (len(ordered) - 1)))]


def _measure(store: Any, n: int, backend: str) -> list[dict[str, Any]]:
    from queries import GraphQuery, run_program, run_program_all

    ids = [s.scene_id for s in store.list_scenes()]
    rows = []
    for label, text in PROGRAMS.items():
        program = GraphQuery.from_text(text)

        def one(program: GraphQuery = program) -> Any:
            return run_program_all(store, program, executor="sql")

        def loop(program: GraphQuery = program) -> Any:
            return [run_program(store, sid, program, executor="sql") for sid in ids]

        rows.append(_row(backend, n, label, ids, one, loop))
    return rows


def _measure_sparql(store: Any, n: int) -> tuple[list[dict[str, Any]], float]:
    """SPARQL rows for every program over the ``n`` stored scans; the load's seconds."""
    from queries import GraphQuery
    from queries.sparql_endpoints import OxigraphEndpoint
    from queries.sparql_executor import SparqlExecutor
    from queries.sparql_many import run_sparql_many

    ids = [s.scene_id for s in store.list_scenes()]
    graphs = [store.load_scene(sid) for sid in ids]
    t0 = time.perf_counter()
    endpoint = OxigraphEndpoint.from_graphs(graphs)
    load_s = time.perf_counter() - t0
    rows = []
    for label, text in PROGRAMS.items():
        program = GraphQuery.from_text(text)

        def one(program: GraphQuery = program) -> Any:
            return run_sparql_many(endpoint, ids, program, all_scenes=True)

        def loop(program: GraphQuery = program) -> Any:
            return [SparqlExecutor(endpoint, sid).run(program) for sid in ids]

        rows.append(_row("sparql-oxigraph", n, label, ids, one, loop))
    return rows, load_s


def _row(
    backend: str,
    n: int,
    label: str,
    ids: list[str],
    one: Callable[[], Any],
    loop: Callable[[], Any],
) -> dict[str, Any]:
    """One table row: ``one`` (every scene at once) against ``loop`` (scene by scene)."""
    one_times, many = _times(one, 15 if n <= 100 else 7)
    loop_times, per_scene = _times(loop, 5 if n <= 100 else 3)
    differ = sum(1 for sid, r in zip(ids, per_scene, strict=True) if many[sid] != r) + abs(
        len(many) - len(per_scene)
    )
    answered = sum(1 for sid in ids if many[sid].answer)
    return {
        "backend": backend,
        "scenes": n,
        "program": label,
        "answered": answered,
        "one_p50_s": _p(one_times, 0.5),
        "one_p95_s": _p(one_times, 0.95),
        "loop_p50_s": _p(loop_times, 0.5),
        "loop_p95_s": _p(loop_times, 0.95),
        "one_repeats": len(one_times),
        "loop_repeats": len(loop_times),
        "differ": differ,
        "one_peak_mib": _peak_mib(one),
        "loop_peak_mib": _peak_mib(loop),
    }


def measure(sizes: tuple[int, ...], root: Path = DATA) -> dict[str, Any]:
    """Ingest growing prefixes of the scans and measure every program at each size."""
    from graph_store import open_store

    scans = all_scans(root)
    sizes = tuple(sorted({min(n, len(scans)) for n in sizes}))
    rows: list[dict[str, Any]] = []
    ingest: list[dict[str, Any]] = []
    sparql_load: list[dict[str, Any]] = []
    version = None
    with tempfile.TemporaryDirectory(prefix="cs-cross-") as tmp, scratch_database() as pg_url:
        folder = Path(tmp)
        stores = {"sqlite": open_store(f"sqlite:///{folder / 'scenes.db'}")}
        if pg_url is not None:
            stores["postgresql"] = open_store(pg_url)
            with stores["postgresql"].engine.connect() as conn:
                version = conn.exec_driver_sql("SHOW server_version").scalar()
        try:
            done = 0
            for n in sizes:
                spent = _ingest(stores, scans[done:n], folder, root)
                ingest.append({"scenes": n, "added": n - done, "seconds": spent})
                done = n
                for backend, store in stores.items():
                    rows.extend(_measure(store, n, backend))
                if n <= SPARQL_MAX_SCENES:
                    sparql_rows, load_s = _measure_sparql(stores["sqlite"], n)
                    rows.extend(sparql_rows)
                    sparql_load.append({"scenes": n, "seconds": load_s})
        finally:
            for store in stores.values():
                store.close()
    entities = sum(len(objects_document(s, root)["objects"]) for s in scans[: sizes[-1]])
    return {
        "rows": rows,
        "ingest": ingest,
        "entities": entities,
        "backends": sorted(stores),
        "sparql_load": sparql_load,
        "postgres_version": version,
        "load": os.getloadavg() if hasattr(os, "getloadavg") else None,
    }


def _ms(seconds: float) -> str:
    ms = seconds * 1000
    return f"{ms:.0f}" if ms >= 100 else f"{ms:.1f}" if ms >= 10 else f"{ms:.2f}"


def _markdown(data: dict[str, Any]) -> str:
    rows = data["rows"]
    largest = max(r["scenes"] for r in rows)
    lines = [
        "One structured program over every stored scene: the one-statement SQL path"
        " (`run_program_all`, `causalsplat query --all-scenes`) against a per-scene loop of"
        ' `run_program(..., executor="sql")` in the same process, on ScanNet object tables'
        f" stored with `ingest-objects` ({largest:,} scans, {data['entities']:,} entities);"
        " SPARQL on Oxigraph (`sparql-oxigraph`, up to"
        f" {SPARQL_MAX_SCENES:,} scans: one query per step for all scans,"
        " `queries.sparql_many`, as `query --all-scenes --executor sparql` runs it once the"
        " scans are loaded) against the per-scene SPARQL executor run scan by scan on the"
        " same in-memory store."
        " Latency after one warm-up run; runs per figure: all at once 15 (100 scans or"
        " fewer) or 7, loop 5 or 3, so p95 is close to the maximum."
        " Programs and method: `causalsplat/bench/cross_scene.py`.",
        "",
    ]
    if data.get("load"):
        one, five, fifteen = data["load"]
        lines += [
            f"Machine: {os.cpu_count()} CPU cores; load average {one:.1f} / {five:.1f} /"
            f" {fifteen:.1f} (1 / 5 / 15 min) when the run ended; absolute times move with"
            " the load, the ratios are measured side by side.",
            "",
        ]
    if data.get("postgres_version"):
        lines += [
            f"PostgreSQL {data['postgres_version']}: a server on the same machine, reached"
            " over TCP on 127.0.0.1; SQLite: a file in a temporary folder.",
            "",
        ]
    lines.append("Goal: every program over all stored scans at p50 <= 1 s on each backend.")
    for backend in sorted({r["backend"] for r in rows}):
        mine = [r for r in rows if r["backend"] == backend]
        most = max(r["scenes"] for r in mine)
        worst = max((r for r in mine if r["scenes"] == most), key=lambda r: r["one_p50_s"])
        met = "**met**" if worst["one_p50_s"] <= GOAL_S else "**not met**"
        lines.append(
            f"- {backend}, {most:,} scans: slowest program p50 {_ms(worst['one_p50_s'])} ms"
            f" ({worst['program']}): {met}."
        )
    differ = sum(r["differ"] for r in rows)
    lines += [
        "",
        f"Agreement: {differ} scene results differ between the two paths over all"
        f" {len(rows)} (backend, size, program) runs.",
        "",
        "| backend | scans | program | scans answered | all at once p50 / p95 (ms) |"
        " per-scene loop p50 / p95 (ms) | loop / one | differ | peak MiB one / loop |",
        "|---|---:|---|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        lines.append(
            f"| {r['backend']} | {r['scenes']:,} | {r['program']} | {r['answered']:,} |"
            f" {_ms(r['one_p50_s'])} / {_ms(r['one_p95_s'])} |"
            f" {_ms(r['loop_p50_s'])} / {_ms(r['loop_p95_s'])} |"
            f" {r['loop_p50_s'] / r['one_p50_s']:.1f}x | {r['differ']} |"
            f" {r['one_peak_mib']:.1f} / {r['loop_peak_mib']:.1f} |"
        )
    lines += ["", "Ingest (`ingest-objects` code path: edges built, scene saved), seconds:", ""]
    lines.append("| scans stored | added | " + " | ".join(data["backends"]) + " |")
    lines.append("|---:|---:|" + "---:|" * len(data["backends"]))
    for step in data["ingest"]:
        secs = " | ".join(f"{step['seconds'][b]:.1f}" for b in data["backends"])
        lines.append(f"| {step['scenes']:,} | {step['added']:,} | {secs} |")
    for load in data.get("sparql_load", ()):
        lines.append(
            f"\nOxigraph: {load['scenes']:,} stored scans loaded into one in-memory store in"
            f" {load['seconds']:.1f} s (untimed in the rows above)."
        )
    if "postgresql" not in data["backends"]:
        lines += ["", "PostgreSQL: not measured (set `CAUSALSPLAT_BENCH_POSTGRES_URL`)."]
    return "\n".join(lines)


def run(*, quick: bool = False) -> BenchReport:
    title = "Questions across scenes: one statement against a per-scene loop"
    if not (DATA / "objects_info").is_dir():
        return BenchReport(
            NAME, title, f"Skipped: the ScanNet object tables are not at `{DATA}`.", {}
        )
    data = measure(QUICK_SIZES if quick else SIZES)
    data["median_ratio"] = statistics.median(r["loop_p50_s"] / r["one_p50_s"] for r in data["rows"])
    return BenchReport(NAME, title, _markdown(data), data)
