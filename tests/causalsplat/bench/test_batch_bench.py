"""The batch benchmark's smoke run: the loop of builds and a 2-worker batch store the same
graphs, and the section reports both with the ratio."""

from __future__ import annotations

from causalsplat.bench.batch import run


def test_batch_bench_quick_run() -> None:
    report = run(quick=True)
    (table,) = report.data["tables"]
    assert table["size"] == "tiny" and table["scenes"] == 2
    rows = table["rows"]
    assert [r["label"] for r in rows] == ["sequential loop of build", "build-many --workers 2"]
    for row in rows:
        assert "error" not in row, row
        assert row["built"] == 2 and row["failed"] == 0 and row["differing"] == 0
        assert row["scenes_per_hour"] > 0 and row["peak_rss_mib"] > 0
    assert "| build-many --workers 2 |" in report.markdown and "0 of 2 |" in report.markdown
    loop = rows[0]
    assert loop["threads_1"] > 0 and loop["threads_2"] > 0
    bound = 2 * loop["threads_2"] / loop["threads_1"]
    assert f"= **{bound:.2f}x** the loop" in report.markdown
