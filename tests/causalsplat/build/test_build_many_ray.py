"""``build-many`` on a local Ray cluster (2 CPUs, started by the test) into PostgreSQL, with
the Ray worker of one scene killed mid-build and the batch resumed."""

from __future__ import annotations

import os
import signal
import threading
import time
from pathlib import Path
from typing import Any

import pytest

from causalsplat.build.batch import build_many
from tests.causalsplat.build.test_build_many import FAST, _rows

pytestmark = [pytest.mark.postgres, pytest.mark.ray]


@pytest.fixture
def ray_cluster() -> Any:
    """A Ray cluster of this process with 2 CPUs, shut down after the test."""
    try:
        import ray
    except ImportError:
        if os.environ.get("CI", "").lower() == "true":
            pytest.fail("Ray is not installed: CI must run the Ray tests (the ray extra)")
        pytest.skip("Ray is not installed (pip install 'causalsplat[ray]')")
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        yield ray
    finally:
        ray.shutdown()


def _task_process(title: str) -> int | None:
    """The pid of the process whose title is ``title`` (Ray titles a worker ``ray::NAME``
    while it runs the task named NAME)."""
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            cmdline = (entry / "cmdline").read_bytes()
        except OSError:
            continue
        if cmdline.replace(b"\0", b" ").strip().decode(errors="replace") == title:
            return int(entry.name)
    return None


class _Killer(threading.Thread):
    """SIGKILLs the Ray worker that runs the task named ``name``, once, when it starts."""

    def __init__(self, name: str) -> None:
        super().__init__(daemon=True)
        self.title = f"ray::{name}"
        self.killed: int | None = None
        self.done = threading.Event()

    def run(self) -> None:
        while not self.done.is_set() and self.killed is None:
            pid = _task_process(self.title)
            if pid is not None:
                os.kill(pid, signal.SIGKILL)
                self.killed = pid
            time.sleep(0.02)


def test_ray_batch_into_postgres_survives_a_killed_worker(
    ray_cluster: Any, batch_folders: list[Path], postgres_url: str
) -> None:
    killer = _Killer("build synth-tiny-1")
    killer.start()
    try:
        first = build_many(batch_folders, postgres_url, ray_address="local", config=FAST,
                           retries=0, cache_dir=False)  # fmt: skip
    finally:
        killer.done.set()
        killer.join()
    assert killer.killed is not None
    assert first.engine == "ray" and first.workers == 2
    by_id = {o.scene_id: o for o in first.outcomes}
    assert by_id["synth-tiny-1"].status == "failed"
    assert "the Ray task failed" in (by_id["synth-tiny-1"].error or "")
    assert by_id["synth-tiny-0"].status == by_id["synth-tiny-2"].status == "built"
    rows = _rows(postgres_url)
    assert sorted(rows) == ["synth-tiny-0", "synth-tiny-2"]  # nothing of the killed scene
    # resumed: the stored scenes are skipped, the killed one is built
    again = build_many(batch_folders, postgres_url, ray_address="local", config=FAST,
                       cache_dir=False)  # fmt: skip
    assert [(o.scene_id, o.status) for o in again.outcomes] == [
        ("synth-tiny-0", "skipped"), ("synth-tiny-1", "built"), ("synth-tiny-2", "skipped"),
    ]  # fmt: skip
    after = _rows(postgres_url)
    assert {k: v for k, v in after.items() if k != "synth-tiny-1"} == rows
    assert after["synth-tiny-1"]["entities"] == again.outcomes[1].entities >= 3
