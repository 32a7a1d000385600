"""Crash safety and concurrent access (DESIGN §4).

A writer process is killed with SIGKILL in the middle of ``save_scene`` (on SQLite and on
PostgreSQL): the database must open, pass ``PRAGMA integrity_check`` (SQLite), hold every
earlier scene unchanged, and show no trace of the half-written one. On SQLite, a reader
keeps reading while another process writes.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import sqlalchemy as sa

from graph_store import SceneNotFound, open_store
from graph_store import models as m
from graph_store._engine import create_store_engine
from tests.conftest import COMMAND_TIMEOUT_S, REPO_ROOT
from tests.strategies import random_scene

WRITER = r"""
import sys
import sqlalchemy as sa
from graph_store import open_store
from tests.strategies import random_scene

url, scene_id, n, loops = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
hold = sys.argv[5:] == ["hold"]
graph = random_scene(scene_id, n, 5 * n, seed=7)
store = open_store(url)
announced = held = False

@sa.event.listens_for(store.engine, "before_cursor_execute")
def announce(conn, cursor, statement, params, context, executemany):
    global announced
    if not announced and statement.startswith("INSERT INTO scenes"):
        announced = True
        print("WRITING", flush=True)

@sa.event.listens_for(store.engine, "commit")
def pause(conn):
    global held
    if hold and announced and not held:  # the scene's write, before it commits
        held = True
        print("HOLDING", flush=True)
        sys.stdin.readline()  # the transaction stays open until a line comes (or a kill)

for _ in range(loops):
    announced = held = False
    store.save_scene(graph, if_exists="replace")
print("DONE", flush=True)
"""


def _writer(
    url: str, scene_id: str, n: int, loops: int = 1, *, hold: bool = False
) -> subprocess.Popen[str]:
    """The writer; ``hold``: each save prints HOLDING before it commits and waits for a
    line on stdin."""
    env = {**os.environ, "PYTHONPATH": str(REPO_ROOT)}
    return subprocess.Popen(
        [sys.executable, "-c", WRITER, url, scene_id, str(n), str(loops), *(["hold"] * hold)],
        stdin=subprocess.PIPE if hold else None,
        stdout=subprocess.PIPE,
        text=True,
        cwd=REPO_ROOT,
        env=env,
    )


def _rows_of(url: str, scene_id: str) -> int:
    engine = create_store_engine(url)
    try:
        with engine.connect() as conn:
            return sum(
                conn.execute(
                    sa.select(sa.func.count()).select_from(t).where(t.c.scene_id == scene_id)
                ).scalar_one()
                for t in (m.entities, m.relations, m.entity_attributes)
            )
    finally:
        engine.dispose()


def _scene_rows(url: str, scene_id: str) -> int:
    engine = create_store_engine(url)
    try:
        with engine.connect() as conn:
            query = (
                sa.select(sa.func.count()).select_from(m.scenes).where(m.scenes.c.id == scene_id)
            )
            return int(conn.execute(query).scalar_one())
    finally:
        engine.dispose()


@pytest.mark.parametrize("delay_s", [0.0, 0.05, 0.3])
def test_sigkill_during_save_leaves_earlier_scenes_and_no_partial_scene(
    db_url: str, delay_s: float
) -> None:
    url = db_url
    earlier = [random_scene(f"earlier-{i}", 300, 1_500, seed=i) for i in range(2)]
    with open_store(url) as store:
        for graph in earlier:
            store.save_scene(graph)

    # held before its commit: however fast this machine, the save is unfinished when killed
    writer = _writer(url, "victim", 20_000, hold=True)
    assert writer.stdout is not None and writer.stdin is not None
    line = writer.stdout.readline()
    assert line.strip() == "WRITING", f"writer did not start writing: {line!r}"
    time.sleep(delay_s)
    writer.send_signal(signal.SIGKILL)
    writer.wait(timeout=COMMAND_TIMEOUT_S)
    writer.stdin.close()
    rest = writer.stdout.read()
    assert writer.returncode == -signal.SIGKILL
    assert "DONE" not in rest, "the writer finished before it was killed; the test proves nothing"

    with open_store(url) as store:
        if store.dialect == "sqlite":
            with store.engine.connect() as conn:
                assert conn.exec_driver_sql("PRAGMA integrity_check").scalar() == "ok"
                assert conn.exec_driver_sql("PRAGMA foreign_key_check").all() == []
        assert [s.scene_id for s in store.list_scenes()] == ["earlier-0", "earlier-1"]
        for graph in earlier:
            assert store.load_scene(graph.scene_id) == graph
        with pytest.raises(SceneNotFound):
            store.load_scene("victim")
    assert _rows_of(url, "victim") == 0
    assert _scene_rows(url, "victim") == 0


def test_reader_keeps_reading_while_another_process_writes(tmp_path: Path) -> None:
    url = f"sqlite:///{tmp_path / 'store.db'}"
    stable = random_scene("stable", 500, 2_500, seed=1)
    with open_store(url) as store:
        store.save_scene(stable)
        # each save holds its write transaction open until the reader has read 3 times
        writer = _writer(url, "moving", 3_000, loops=3, hold=True)
        assert writer.stdout is not None and writer.stdin is not None
        reads = 0
        seen_moving = 0
        try:
            for _ in range(3):
                assert writer.stdout.readline().strip() == "WRITING"
                assert writer.stdout.readline().strip() == "HOLDING"
                for _ in range(3):
                    assert store.load_scene("stable") == stable
                    reads += 1
                    for summary in store.list_scenes():
                        if summary.scene_id == "moving":  # present means complete, never partial
                            seen_moving += 1
                            assert summary.entity_count == 3_000
                writer.stdin.write("commit\n")
                writer.stdin.flush()
            writer.stdin.close()
            rest = writer.stdout.read()
            writer.wait(timeout=COMMAND_TIMEOUT_S)
        finally:
            if writer.poll() is None:
                writer.kill()
                writer.communicate()
        assert writer.returncode == 0 and rest.strip() == "DONE", rest
        assert reads >= 3, "the reader was blocked while the writer wrote"
        assert store.load_scene("moving").entities[-1].id == 2_999
        assert seen_moving >= 1
