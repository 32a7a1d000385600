"""``causalsplat synth`` and ``causalsplat prepare-scannet`` through the real command line."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import COMMAND_TIMEOUT_S, REPO_ROOT


def run(*args: str, check: bool = True) -> subprocess.CompletedProcess[str]:
    argv = [sys.executable, "-m", "causalsplat", *args]
    proc = subprocess.run(
        argv,
        capture_output=True,
        text=True,
        cwd=REPO_ROOT,
        env={**os.environ},
        timeout=COMMAND_TIMEOUT_S,
    )
    if check and proc.returncode != 0:
        raise AssertionError(f"{argv} failed ({proc.returncode}): {proc.stderr}")
    return proc


def assert_one_line_error(proc: subprocess.CompletedProcess[str], pattern: str) -> None:
    assert proc.returncode != 0
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith("causalsplat: error: ")
    assert pattern in lines[0], lines[0]


@pytest.mark.parametrize("command", ["synth", "prepare-scannet"])
def test_help(command: str) -> None:
    out = run(command, "--help").stdout
    assert "Usage:" in out and "--json" in out and len(out.splitlines()) > 8


def test_synth_tiny_json_and_same_bytes_as_the_api(tmp_path: Path) -> None:
    out = tmp_path / "scene"
    doc = json.loads(run("synth", "--size", "tiny", "--seed", "0", "-o", str(out), "--json").stdout)
    assert doc["scene_id"] == "synth-tiny-0" and doc["n_views"] == 12
    assert set(doc["queries_by_type"]) >= {"spatial", "commonsense", "affordance", "counterfactual"}
    assert Path(doc["files"]["point_cloud"]).is_file()
    # another process, through the Python API, writes the very same bytes
    from causalsplat.synth import synth_scene

    synth_scene("tiny", 0, tmp_path / "api")
    files = sorted(p.relative_to(out) for p in out.rglob("*") if p.is_file())
    assert files == sorted(
        p.relative_to(tmp_path / "api") for p in (tmp_path / "api").rglob("*") if p.is_file()
    )
    for rel in files:
        assert (out / rel).read_bytes() == (tmp_path / "api" / rel).read_bytes(), rel
    # the objects file is accepted by ingest-objects
    db = f"sqlite:///{tmp_path / 'store.db'}"
    ingested = json.loads(
        run("ingest-objects", str(out / "objects.json"), "--json", "--db", db).stdout
    )
    assert ingested["scene_id"] == "synth-tiny-0" and ingested["entities"] == doc["n_entities"]


def test_synth_text_summary_and_noise(tmp_path: Path) -> None:
    text = run("synth", "--seed", "2", "--noise", "0", "-o", str(tmp_path / "s")).stdout
    assert "synth-tiny-2" in text and "gaussians" in text and "queries" in text


def test_synth_bad_inputs(tmp_path: Path) -> None:
    assert_one_line_error(
        run("synth", "--size", "huge", "-o", str(tmp_path / "a"), check=False),
        "unknown size 'huge'",
    )
    assert_one_line_error(
        run("synth", "--noise", "-1", "-o", str(tmp_path / "a"), check=False), "noise_strength"
    )
    assert_one_line_error(
        run("synth", "--seed", "-1", "-o", str(tmp_path / "a"), check=False),
        "SynthConfig.seed must be an integer in [0, inf), got -1",
    )
    blocker = tmp_path / "file"
    blocker.write_text("x")
    assert_one_line_error(
        run("synth", "-o", str(blocker / "scene"), check=False), "is not a folder"
    )
    busy = tmp_path / "busy"
    busy.mkdir()
    (busy / "keep.txt").write_text("x")
    assert_one_line_error(run("synth", "-o", str(busy), check=False), "not empty")
    assert_one_line_error(
        run("synth", "-o", str(busy), "--overwrite", check=False), "not a scene folder"
    )
    assert not (tmp_path / "a").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["busy", "file"]


def test_prepare_scannet_bad_inputs(tmp_path: Path) -> None:
    assert_one_line_error(
        run("prepare-scannet", str(tmp_path / "nope"), "-o", str(tmp_path / "o"), check=False),
        "No such ScanNet source folder",
    )
    (tmp_path / "src").mkdir()
    assert_one_line_error(
        run("prepare-scannet", str(tmp_path / "src"), "-o", str(tmp_path / "o"), check=False),
        "not found",
    )
    assert_one_line_error(
        run("prepare-scannet", str(tmp_path / "src"), "-o", str(tmp_path / "o"), "--width", "0",
            check=False),
        "image size",
    )  # fmt: skip
    assert not (tmp_path / "o").exists()
