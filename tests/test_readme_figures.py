"""The README's measured figures are the benchmark report's: every percentage with a
decimal (86.1 %) and every panoptic quality (PQ 0.647) the README states must appear in
``docs/benchmarks.md``, which ``causalsplat bench`` writes. A figure left behind by a rerun
fails here instead of misleading a reader."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PERCENT = re.compile(r"(\d+\.\d+) ?%")
PQ = re.compile(r"PQ (\d\.\d{3})")


def _figures(text: str) -> set[str]:
    return set(PERCENT.findall(text)) | {f"PQ {v}" for v in PQ.findall(text)}


def test_every_readme_figure_is_in_the_benchmark_report() -> None:
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    report = (ROOT / "docs" / "benchmarks.md").read_text(encoding="utf-8")
    stated = _figures(readme)
    assert stated, "the README states no figure"
    # the report writes PQ in table cells; a README "PQ 0.647" must be one of them
    measured = set(PERCENT.findall(report)) | {
        f"PQ {v}" for v in re.findall(r"\b(\d\.\d{3})\b", report)
    }
    missing = sorted(stated - measured)
    assert not missing, f"README figures not in docs/benchmarks.md: {missing}"
