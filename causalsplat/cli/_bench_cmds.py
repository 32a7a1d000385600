"""The ``bench`` command: run benchmarks and update docs/benchmarks.md."""

from __future__ import annotations

import shlex
import sys
from pathlib import Path

import click

from causalsplat.cli._app import cli, echo_json, json_option


@cli.command("bench")
@click.option("--only", "names", multiple=True, help="Run only this benchmark (repeatable).")
@click.option("--quick", is_flag=True, help="Smaller sizes, for a smoke run.")
@click.option(
    "--report",
    type=click.Path(dir_okay=False, path_type=Path),
    default=Path("docs/benchmarks.md"),
    show_default=True,
    help="Markdown report whose sections are replaced.",
)
@json_option
def bench(names: tuple[str, ...], quick: bool, report: Path, as_json: bool) -> None:
    """Run the benchmarks (error against run time, ratios against in-run baselines)."""
    from causalsplat.bench import BENCHMARKS, run_benchmarks

    command = "causalsplat " + " ".join(shlex.quote(a) for a in sys.argv[1:])
    reports = run_benchmarks(
        names or BENCHMARKS, quick=quick, report_path=report, command=command.strip()
    )
    if as_json:
        echo_json({r.name: r.data for r in reports})
        return
    for r in reports:
        click.echo(f"## {r.title}\n\n{r.markdown}\n")
    click.echo(f"updated {report}")
