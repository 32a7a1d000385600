"""Benchmarks (``causalsplat bench`` / ``make bench``), written to ``docs/benchmarks.md``.

Each benchmark module in this package exposes ``NAME`` (a short id; a ``-`` in it is a
``_`` in the module's name) and
``run(*, quick: bool = False) -> BenchReport``. ``run_benchmarks`` runs the selected
ones and replaces each one's section of the report between the markers
``<!-- bench:NAME:start -->`` and ``<!-- bench:NAME:end -->``, so sections produced by
other runs stay as they are. Every benchmark measures its baseline in the same
process and reports ratios, never absolute times alone.
"""

from __future__ import annotations

import importlib
import platform
import re
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

#: Benchmark modules, in report order. A module listed here that is not importable
#: (its optional dependencies missing) is reported as skipped.
BENCHMARKS: tuple[str, ...] = (
    "store", "queries", "render", "edges", "build", "scale", "batch", "reasoning",
    "cross-scene", "serve",
)  # fmt: skip


@dataclass(frozen=True, slots=True)
class BenchReport:
    """One benchmark's result: a markdown section and the raw numbers behind it."""

    name: str
    title: str
    markdown: str
    data: dict[str, Any] = field(default_factory=dict)
    #: PNG plots by file name, written next to the report (the markdown links them).
    images: dict[str, bytes] = field(default_factory=dict)


def _section(name: str, body: str) -> str:
    return f"<!-- bench:{name}:start -->\n{body.rstrip()}\n<!-- bench:{name}:end -->"


def update_report(path: Path, report: BenchReport, *, command: str) -> None:
    """Replace (or append) ``report``'s section in the markdown file at ``path``."""
    stamp = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    machine = (
        f"{platform.machine()}, {platform.python_implementation()} {platform.python_version()}"
    )
    body = (
        f"## {report.title}\n\n"
        f"Command: `{command}` (run {stamp}, {machine}).\n\n{report.markdown.strip()}\n"
    )
    text = path.read_text(encoding="utf-8") if path.exists() else "# Benchmarks\n"
    name = re.escape(report.name)
    pattern = re.compile(rf"<!-- bench:{name}:start -->.*?<!-- bench:{name}:end -->", re.DOTALL)
    new = _section(report.name, body)
    if pattern.search(text):
        text = pattern.sub(lambda _m: new, text)
    else:
        text = text.rstrip() + "\n\n" + new + "\n"
    path.write_text(text, encoding="utf-8")


def run_benchmarks(
    names: tuple[str, ...] | None = None,
    *,
    quick: bool = False,
    report_path: Path | None = None,
    command: str = "causalsplat bench",
) -> list[BenchReport]:
    """Run benchmarks by name (all when ``None``) and update the report file."""
    selected = names or BENCHMARKS
    unknown = sorted(set(selected) - set(BENCHMARKS))
    if unknown:
        from causalsplat.errors import CausalSplatError

        raise CausalSplatError(
            f"unknown benchmark(s) {', '.join(unknown)}; known: {', '.join(BENCHMARKS)}"
        )
    reports = []
    for name in selected:
        module = importlib.import_module(f"causalsplat.bench.{name.replace('-', '_')}")
        report: BenchReport = module.run(quick=quick)
        reports.append(report)
        if report_path is not None:
            update_report(report_path, report, command=command)
            for file_name, png in report.images.items():
                (report_path.parent / file_name).write_bytes(png)
    return reports
