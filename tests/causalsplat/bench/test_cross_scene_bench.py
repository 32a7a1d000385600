"""The cross-scene benchmark's smoke run on 20 ScanNet scans: the one-statement SQL path,
the one-query-per-step SPARQL path and their per-scene loops give equal results for every
scan, and the report says so."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from causalsplat.bench.cross_scene import PROGRAMS, _markdown, measure
from tests.conftest import shared_data_path


@pytest.mark.shared_data
def test_twenty_scans_agree() -> None:
    root = shared_data_path("referit3d_scannet_objects")
    data = measure((20,), root)
    rows = data["rows"]
    assert {r["program"] for r in rows} == set(PROGRAMS)
    server = os.environ.get("CAUSALSPLAT_BENCH_POSTGRES_URL") or os.environ.get(
        "CAUSALSPLAT_TEST_POSTGRES_URL"
    )
    with_server = {"postgresql"} if server else set()
    assert {r["backend"] for r in rows} == {"sqlite", "sparql-oxigraph"} | with_server
    assert all(r["scenes"] == 20 and r["differ"] == 0 for r in rows)
    answered = {(r["backend"], r["program"]): r["answered"] for r in rows}
    assert any(answered.values())
    assert all(answered["sqlite", p] == answered["sparql-oxigraph", p] for p in PROGRAMS)
    assert [load["scenes"] for load in data["sparql_load"]] == [20]
    text = _markdown(data)
    assert "Agreement: 0 scene results differ" in text
    assert "| sparql-oxigraph | 20 |" in text and "Oxigraph: 20 stored scans loaded" in text


def test_registered_and_skips_cleanly_without_the_data(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from causalsplat.bench import cross_scene, run_benchmarks

    monkeypatch.setattr(cross_scene, "DATA", tmp_path / "absent")
    report = tmp_path / "benchmarks.md"
    (only,) = run_benchmarks(("cross-scene",), quick=True, report_path=report)
    assert only.name == "cross-scene" and only.markdown.startswith("Skipped:")
    text = report.read_text(encoding="utf-8")
    assert "<!-- bench:cross-scene:start -->" in text and "<!-- bench:cross-scene:end -->" in text
