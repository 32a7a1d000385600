"""The cross-scene benchmark's smoke run on 20 ScanNet scans: the one-statement path and
the per-scene loop give equal results for every scan, and the report says so."""

from __future__ import annotations

import pytest

from causalsplat.bench.cross_scene import PROGRAMS, _markdown, measure
from tests.conftest import shared_data_path


@pytest.mark.shared_data
def test_twenty_scans_agree() -> None:
    root = shared_data_path("referit3d_scannet_objects")
    data = measure((20,), root)
    rows = data["rows"]
    assert {r["program"] for r in rows} == set(PROGRAMS)
    assert all(r["scenes"] == 20 and r["differ"] == 0 for r in rows)
    assert any(r["answered"] > 0 for r in rows)
    text = _markdown(data)
    assert "Agreement: 0 scene results differ" in text
