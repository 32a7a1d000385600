"""``build-many``: a batch of synthetic scenes built by worker processes into SQLite and
PostgreSQL, a worker killed with SIGKILL mid-build, and the batch resumed."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest
import sqlalchemy as sa

from causalsplat import open_store
from causalsplat.build import BuildConfig
from causalsplat.build.batch import BatchError, build_many
from causalsplat.field import FieldConfig
from tests.causalsplat.test_cli_store import assert_one_line_error, run
from tests.conftest import COMMAND_TIMEOUT_S, REPO_ROOT

FAST = BuildConfig(field=FieldConfig(iterations=40))


def _rows(url: str) -> dict[str, dict[str, int]]:
    """Rows of every scene-owned table per scene id, read straight from the database."""
    from graph_store import models as m

    engine = sa.create_engine(url)
    out: dict[str, dict[str, int]] = {}
    try:
        with engine.connect() as conn:
            for table in (m.entities, m.relations, m.views, m.masks, m.gaussian_labels):
                query = sa.select(table.c.scene_id, sa.func.count()).group_by(table.c.scene_id)
                for sid, n in conn.execute(query):
                    out.setdefault(sid, {})[table.name] = n
    finally:
        engine.dispose()
    return out


def test_batch_builds_skips_and_reports(
    batch_folders: list[Path], db_url: str, tmp_path: Path
) -> None:
    broken = tmp_path / "broken"
    broken.mkdir()
    (broken / "point_cloud.ply").write_bytes(b"not a ply\n")
    lines: list[str] = []
    report_file = tmp_path / "report.jsonl"
    with open_store(db_url) as store:
        report = store.build_many(
            [*batch_folders, broken], workers=2, config=FAST, cache_dir=tmp_path / "cache",
            report_path=report_file, progress=lines.append,
        )  # fmt: skip
        stored = {s.scene_id: s for s in store.scenes()}
        single = store.graph_store.load_scene("synth-tiny-1")
    ids = ["synth-tiny-0", "synth-tiny-1", "synth-tiny-2"]
    assert [o.scene_id for o in report.outcomes] == [*ids, "broken"]
    assert (report.built, report.skipped, report.failed, report.workers) == (3, 0, 1, 2)
    bad = report.outcomes[3]
    # a malformed folder fails once (not retried: it would fail again), naming the file
    assert bad.status == "failed" and bad.attempts == 1 and "point_cloud.ply" in bad.error
    for o in report.outcomes[:3]:
        assert o.status == "built" and o.attempts == 1 and o.error is None
        assert o.entities == stored[o.scene_id].entity_count >= 3 and o.peak_rss_mib > 0
    assert sorted(stored) == ids and report.scenes_per_hour > 0
    assert (
        single.meta.source == "build"
        and len(single.entities) == stored["synth-tiny-1"].entity_count
    )
    # progress lines: a start and an end per scene
    assert sum(line.startswith("[start] ") for line in lines) == 4
    assert any(line.startswith("[4/4] ") for line in lines)
    assert any("synth-tiny-0 built in" in line and "entities" in line for line in lines)
    records = [json.loads(line) for line in report_file.read_text().splitlines()]
    assert sorted(r["scene_id"] for r in records[:4]) == sorted([*ids, "broken"])
    assert records[-1]["summary"]["built"] == 3 and records[-1]["summary"]["failed"] == 1

    # run again: the stored scenes are skipped, nothing is rebuilt or duplicated
    before = _rows(db_url)
    again = build_many(batch_folders, db_url, workers=2, config=FAST, cache_dir=False)
    assert [o.status for o in again.outcomes] == ["skipped"] * 3
    assert _rows(db_url) == before
    # changed options: a stored scene is not replaced unless asked to
    other = BuildConfig(field=FieldConfig(iterations=41))
    changed = build_many(batch_folders[:1], db_url, config=other, cache_dir=False)
    assert changed.failed == 1 and "other options" in (changed.outcomes[0].error or "")
    assert changed.outcomes[0].attempts == 1 and _rows(db_url) == before
    replaced = build_many(
        batch_folders[:1], db_url, config=other, if_exists="replace", cache_dir=tmp_path / "c2"
    )
    assert replaced.built == 1
    with open_store(db_url) as store:
        assert sorted(s.scene_id for s in store.scenes()) == ids
        assert store.graph_store.scene_meta("synth-tiny-0").config_hash != (
            store.graph_store.scene_meta("synth-tiny-1").config_hash
        )


def _start_batch(*args: str) -> subprocess.Popen[str]:
    argv = [sys.executable, "-m", "causalsplat", "build-many", *args]
    return subprocess.Popen(argv, cwd=REPO_ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)  # fmt: skip


def _run_killing(args: list[str], victim: str, attempt: int) -> tuple[int, str, list[str]]:
    """Run ``build-many``; SIGKILL the worker that starts ``victim``'s ``attempt``."""
    proc = _start_batch(*args)
    assert proc.stderr is not None
    lines, killed = [], False
    marker = f"[start] {victim} on worker pid "
    for line in proc.stderr:
        lines.append(line.rstrip("\n"))
        text = line.removeprefix("causalsplat: ")
        if not killed and text.startswith(marker) and f"(attempt {attempt} of" in text:
            os.kill(int(text[len(marker) :].split()[0]), signal.SIGKILL)
            killed = True
    out, _ = proc.communicate(timeout=COMMAND_TIMEOUT_S)
    assert killed, lines
    return proc.returncode, out, lines


def test_killed_worker_loses_only_its_scene_and_the_batch_resumes(
    batch_folders: list[Path], db_url: str, tmp_path: Path
) -> None:
    config = tmp_path / "fast.json"
    config.write_text(json.dumps({"field": {"iterations": 40}}))
    args = [*map(str, batch_folders), "--db", db_url, "--config", str(config), "--no-cache",
            "--workers", "2", "--json", "--progress"]  # fmt: skip
    # no retry: the killed scene fails, the others are built
    rc, out, lines = _run_killing([*args, "--retries", "0"], "synth-tiny-1", attempt=1)
    assert rc == 1 and lines[-1].startswith("causalsplat: error: 1 of 3 scenes failed")
    doc = json.loads(out)
    by_id = {o["scene_id"]: o for o in doc["outcomes"]}
    assert by_id["synth-tiny-1"]["status"] == "failed"
    assert "worker process died (killed by SIGKILL)" in by_id["synth-tiny-1"]["error"]
    assert by_id["synth-tiny-0"]["status"] == by_id["synth-tiny-2"]["status"] == "built"
    rows = _rows(db_url)
    assert sorted(rows) == ["synth-tiny-0", "synth-tiny-2"]  # nothing of the killed scene
    # resumed: only the missing scene is built; its worker is killed once more and the
    # retry builds it
    rc, out, lines = _run_killing(args, "synth-tiny-1", attempt=1)
    assert rc == 0, lines
    doc = json.loads(out)
    assert [(o["scene_id"], o["status"], o["attempts"]) for o in doc["outcomes"]] == [
        ("synth-tiny-0", "skipped", 1), ("synth-tiny-1", "built", 2),
        ("synth-tiny-2", "skipped", 1),
    ]  # fmt: skip
    assert any(line.startswith("causalsplat: [retry] synth-tiny-1 failed") for line in lines)
    after = _rows(db_url)
    assert {k: v for k, v in after.items() if k != "synth-tiny-1"} == rows
    with open_store(db_url) as store:
        summaries = {s.scene_id: s for s in store.scenes()}
        assert sorted(summaries) == ["synth-tiny-0", "synth-tiny-1", "synth-tiny-2"]
        for sid, counts in after.items():  # every stored scene whole, none twice
            graph = store.graph_store.load_scene(sid)
            assert counts["entities"] == len(graph.entities) == summaries[sid].entity_count
            assert counts["gaussian_labels"] == 1


def test_batch_refuses_before_anything_runs(batch_folders: list[Path], tmp_path: Path) -> None:
    db = tmp_path / "never.db"
    twin = tmp_path / "twin"
    twin.mkdir()
    (twin / "queries.json").write_text(json.dumps({"scene_id": "synth-tiny-0", "queries": []}))
    proc = run("build-many", str(batch_folders[0]), str(twin), db=f"sqlite:///{db}", check=False)
    assert_one_line_error(proc, "scene id 'synth-tiny-0' comes from two folders")
    missing = run("build-many", str(tmp_path / "nope"), db=f"sqlite:///{db}", check=False)
    assert_one_line_error(missing, "does not exist")
    assert not db.exists()
    with pytest.raises(BatchError, match="in-memory"):
        build_many(batch_folders, "sqlite://")
    with pytest.raises(BatchError, match="retries"):
        build_many(batch_folders, f"sqlite:///{db}", retries=-1)


def test_concurrent_saves_from_several_processes(tmp_path: Path) -> None:
    """Four processes storing scenes into one SQLite file at once all succeed (WAL, the
    busy timeout and BEGIN IMMEDIATE queue the writers)."""
    db = f"sqlite:///{tmp_path / 'many.db'}"
    with open_store(db) as store:
        store.graph_store.initialise()  # the workers open it with create=False
    script = (
        "import sys\n"
        "from causalsplat import open_store\n"
        "from causalsplat.objects import objects_to_scene_graph, read_objects\n"
        "w = sys.argv[1]\n"
        "with open_store(sys.argv[2], create=False) as s:\n"
        "    for i in range(5):\n"
        "        g = objects_to_scene_graph(read_objects(sys.argv[3]), scene_id=f'w{w}-{i}')\n"
        "        s.save_scene(g)\n"
    )
    objects = tmp_path / "objects.json"
    objects.write_text(json.dumps({"scene_id": "x", "objects": [
        {"id": k, "label": "box", "center": [k, 0, 0.5], "size": [0.5, 0.5, 1]}
        for k in range(30)
    ]}))  # fmt: skip
    procs = [
        subprocess.Popen(
            [sys.executable, "-c", script, str(w), db, str(objects)],
            cwd=REPO_ROOT,
            stderr=subprocess.PIPE,
            text=True,
        )
        for w in range(4)
    ]
    errors = [p.communicate(timeout=COMMAND_TIMEOUT_S)[1] for p in procs]
    assert [p.returncode for p in procs] == [0] * 4, errors
    rows = _rows(db)
    assert len(rows) == 20 and all(r["entities"] == 30 for r in rows.values())
