"""The serve load benchmark's smoke run: 50 clients against the new server and the old one
in the same run; the new one answers every request."""

from __future__ import annotations

from causalsplat.bench import serve


def test_serve_bench_measures_both_servers() -> None:
    data = serve.measure(1.0)
    rows = data["rows"]
    assert list(rows) == [
        "http.server (baseline), a connection per request",
        "uvicorn, a connection per request",
        "uvicorn, kept-alive connections",
    ]
    for label, row in rows.items():
        assert row["requests"] > 0 and row["peak_rss_mib"] > 0, label
        assert row["p50_ms"] <= row["p99_ms"] <= row["max_ms"], label
    for label in list(rows)[1:]:
        assert rows[label]["failed"] == 0, rows[label]["failures"]
    text = serve._markdown(data)
    assert "| uvicorn, kept-alive connections |" in text and "p99 / baseline" in text
