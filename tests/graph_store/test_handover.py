"""Handing a live SQLite store over: its ``.db`` file alone holds every committed scene
(a checkpoint after each write), and ``backup`` copies it while it is in use."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from graph_store import StoreConnectionError, open_store
from tests.conftest import COMMAND_TIMEOUT_S, REPO_ROOT
from tests.strategies import random_scene


def test_the_db_file_alone_holds_every_scene_while_a_reader_has_it_open(
    tmp_path: Path,
) -> None:
    url = f"sqlite:///{tmp_path / 'live.db'}"
    with open_store(url) as reader, open_store(url) as writer:
        assert reader.list_scenes() == []  # a reader with the store open, as serve has it
        for k in range(3):
            writer.save_scene(random_scene(f"s{k}", 300, 900, seed=k))
        assert len(reader.list_scenes()) == 3
        # copy the .db file only, as a user copies "the store" with cp or scp
        shutil.copyfile(tmp_path / "live.db", tmp_path / "copy.db")
    with open_store(f"sqlite:///{tmp_path / 'copy.db'}", create=False) as copy:
        assert [s.scene_id for s in copy.list_scenes()] == ["s0", "s1", "s2"]
        assert copy.load_scene("s2") == random_scene("s2", 300, 900, seed=2)


def test_backup_copies_a_store_in_use_and_refuses_to_overwrite(tmp_path: Path) -> None:
    url = f"sqlite:///{tmp_path / 'live.db'}"
    with open_store(url) as store:
        store.save_scene(random_scene("a", 50, 100))
        # a read transaction held open across the backup
        with store.engine.connect() as held, held.begin():
            assert held.exec_driver_sql("SELECT count(*) FROM entities").scalar() == 50
            out = store.backup(tmp_path / "backup.db")
        assert not (tmp_path / "backup.db-wal").exists()
        with pytest.raises(FileExistsError):
            store.backup(out)
    with open_store(f"sqlite:///{out}", create=False) as copy:
        assert copy.load_scene("a") == random_scene("a", 50, 100)


def test_db_backup_command(tmp_path: Path) -> None:
    url = f"sqlite:///{tmp_path / 'live.db'}"
    with open_store(url) as store:
        store.save_scene(random_scene("a", 20, 40))

    def run(*args: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run([sys.executable, "-m", "causalsplat", "db", *args, "--db", url],
                              capture_output=True, text=True, cwd=REPO_ROOT,
                              timeout=COMMAND_TIMEOUT_S)  # fmt: skip

    done = run("backup", str(tmp_path / "b.db"))
    assert done.returncode == 0 and "backed up 1 scene(s)" in done.stdout, done.stderr
    again = run("backup", str(tmp_path / "b.db"))
    assert again.returncode == 1
    assert (
        again.stderr.strip() == f"causalsplat: error: the backup target exists: {tmp_path / 'b.db'}"
    )


def test_backup_of_a_postgres_store_points_to_pg_dump(postgres_url: str) -> None:
    with open_store(postgres_url) as store, pytest.raises(StoreConnectionError, match="pg_dump"):
        store.backup("never.db")
