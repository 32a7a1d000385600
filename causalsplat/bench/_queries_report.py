"""Markdown tables of the query benchmark (see :mod:`causalsplat.bench.queries`)."""

from __future__ import annotations

import math
from typing import Any

GOALS = {("sql-sqlite", 4): 10.0, ("sparql-oxigraph", 4): 20.0}  # p50 ms at 10k entities
GOAL_SIZE = 10_000


def _fmt(ms: float) -> str:
    return f"{ms:.2f}" if ms < 10 else f"{ms:.1f}" if ms < 100 else f"{ms:.0f}"


def _by(rows: list[dict[str, Any]]) -> dict[tuple[int, str, int], dict[str, Any]]:
    return {(r["entities"], r["executor"], r["steps"]): r for r in rows}


def _latency_table(rows: list[dict[str, Any]], sizes: tuple[int, ...]) -> list[str]:
    index = _by(rows)
    executors = list(dict.fromkeys(r["executor"] for r in rows))
    out = [
        "| entities | steps | " + " | ".join(f"{e} p50 / p95 (ms)" for e in executors) + " |",
        "|---:|---:|" + "---:|" * len(executors),
    ]
    for n in sizes:
        for steps in (1, 4, 8):
            cells = []
            for e in executors:
                r = index.get((n, e, steps))
                if r is None:
                    cells.append("-")
                else:
                    mark = "" if r["agrees"] else " (DIFFERS)"
                    cells.append(f"{_fmt(r['p50_ms'])} / {_fmt(r['p95_ms'])}{mark}")
            out.append(f"| {n:,} | {steps} | " + " | ".join(cells) + " |")
    return out


def _ratio_table(rows: list[dict[str, Any]], sizes: tuple[int, ...]) -> list[str]:
    index = _by(rows)
    others = [e for e in dict.fromkeys(r["executor"] for r in rows) if e != "networkx"]
    out = [
        "| entities | steps | networkx p50 (ms) | "
        + " | ".join(f"{e} / networkx" for e in others)
        + " |",
        "|---:|---:|---:|" + "---:|" * len(others),
    ]
    for n in sizes:
        for steps in (1, 4, 8):
            ref = index.get((n, "networkx", steps))
            if ref is None:
                continue
            cells = []
            for e in others:
                r = index.get((n, e, steps))
                cells.append("-" if r is None else f"{r['p50_ms'] / ref['p50_ms']:.2f}x")
            out.append(f"| {n:,} | {steps} | {_fmt(ref['p50_ms'])} | " + " | ".join(cells) + " |")
    return out


def _growth(rows: list[dict[str, Any]]) -> list[str]:
    """Least-squares slope of log(p50) against log(entities), per executor and program."""
    series: dict[tuple[str, int], list[tuple[float, float]]] = {}
    for r in rows:
        series.setdefault((r["executor"], r["steps"]), []).append(
            (math.log(r["entities"]), math.log(r["p50_ms"]))
        )
    out = ["| executor | 1 step | 4 steps | 8 steps |", "|---|---:|---:|---:|"]
    for e in dict.fromkeys(key[0] for key in series):
        cells = []
        for steps in (1, 4, 8):
            pts = series.get((e, steps), [])
            if len(pts) < 2:
                cells.append("-")
                continue
            mx = sum(x for x, _ in pts) / len(pts)
            my = sum(y for _, y in pts) / len(pts)
            sxx = sum((x - mx) ** 2 for x, _ in pts)
            slope = sum((x - mx) * (y - my) for x, y in pts) / sxx
            cells.append(f"{slope:.2f} ({len(pts)} sizes)")
        out.append(f"| {e} | " + " | ".join(cells) + " |")
    return out


def _setup_table(rows: list[dict[str, Any]], sizes: tuple[int, ...]) -> list[str]:
    index = _by(rows)
    executors = list(dict.fromkeys(r["executor"] for r in rows))
    out = [
        "| entities | relations | " + " | ".join(executors) + " |",
        "|---:|---:|" + "---:|" * len(executors),
    ]
    for n in sizes:
        rels = next((r["relations"] for r in rows if r["entities"] == n), 0)
        cells = [
            f"{index[(n, e, 1)]['setup_s']:.2f}" if (n, e, 1) in index else "-" for e in executors
        ]
        out.append(f"| {n:,} | {rels:,} | " + " | ".join(cells) + " |")
    return out


def _goals(rows: list[dict[str, Any]]) -> list[str]:
    index = _by(rows)
    out = []
    for (executor, steps), goal in GOALS.items():
        r = index.get((GOAL_SIZE, executor, steps))
        if r is None:
            out.append(f"- {executor}, {steps}-step program at {GOAL_SIZE:,} entities: not measured"
                       " (quick run).")  # fmt: skip
            continue
        verdict = "met" if r["p50_ms"] < goal else "NOT met"
        scene = index.get((GOAL_SIZE, executor, 1))
        part = (
            f" (the 1-step program, which only returns the scene's {GOAL_SIZE:,} ids that every"
            f" result carries as its step 0, takes {_fmt(scene['p50_ms'])} ms of that)"
            if scene
            else ""
        )
        out.append(
            f"- {executor}, {steps}-step relate program at {GOAL_SIZE:,} entities: p50"
            f" {_fmt(r['p50_ms'])} ms against a goal of {goal:.0f} ms: **{verdict}**{part}."
        )
    return out


def render(rows: list[dict[str, Any]], sizes: tuple[int, ...], machine: str) -> str:
    differing = [r for r in rows if not r["agrees"]]
    lines = [
        "Latency of one whole program run (every step's set computed and returned), after a"
        " warm-up run, on a prepared executor. Programs and scenes: see"
        f" `causalsplat/bench/queries.py`. Machine: {machine}; with other jobs on the same"
        " cores, absolute times are noisy and the ratios (measured in the same run) are what"
        " to compare.",
        "",
        "Goals:",
        *_goals(rows),
        "",
        f"Agreement with the networkx reference: {len(rows) - len(differing)} of {len(rows)}"
        " measured (executor, size, program) results equal"
        + ("." if not differing else f"; differing: {differing}."),
        "",
        "### Latency (p50 / p95, ms)",
        "",
        *_latency_table(rows, sizes),
        "",
        "### Ratio to the networkx reference (p50)",
        "",
        *_ratio_table(rows, sizes),
        "",
        "### Growth with scene size",
        "",
        "Slope of log(p50) against log(entities) (1 = linear in the scene size):",
        "",
        *_growth(rows),
        "",
        "### One-off preparation (s)",
        "",
        "networkx: build the graph; sql: save the scene into the database; sparql: load the"
        " scene's RDF view into a fresh store.",
        "",
        *_setup_table(rows, sizes),
    ]
    return "\n".join(lines)
