"""The local pool of a batch: worker processes on this machine, watched by the driver.

``concurrent.futures.ProcessPoolExecutor`` marks the whole pool broken when one worker
dies, failing every scene in flight. Here each worker is a long-lived process (started
with ``spawn``: no state of the driver is inherited) with a pipe of its own; the driver
hands it one scene at a time and waits on the pipes and on the processes' sentinels
together. A worker that dies (SIGKILL, the kernel's out-of-memory killer) fails only the
attempt of the scene it held, whose transaction never committed; the driver starts a
new worker in its place and goes on. Workers ignore SIGINT (the driver stops them) and
exit when the driver's end of their pipe closes, so they never outlive it by more than
the scene they are building.
"""

from __future__ import annotations

import multiprocessing as mp
import os
import signal
import time
from collections import deque
from collections.abc import Collection, Iterator
from contextlib import contextmanager, suppress
from multiprocessing.connection import Connection, wait
from multiprocessing.process import BaseProcess
from typing import TYPE_CHECKING

from causalsplat.build.batch import SceneOutcome, SceneTask

if TYPE_CHECKING:
    from causalsplat.build.batch import _Events

#: Thread-count variables of the numerical libraries, set in a worker's environment to its
#: threads (unless already set) so that ``workers`` workers do not oversubscribe the cores.
THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


def _worker_main(conn: Connection) -> None:
    """A worker: receive ``(task, attempt)``, send back ``(outcome, retry)``, until
    ``None`` or the driver's end of the pipe closes."""
    from causalsplat.build._batch_scene import run_scene

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    while True:
        try:
            message = conn.recv()
        except (EOFError, OSError):
            return
        if message is None:
            return
        task, attempt = message
        result = run_scene(task, attempt)
        try:
            conn.send(result)
        except (BrokenPipeError, OSError):
            return


class _Worker:
    def __init__(self, ctx: mp.context.SpawnContext) -> None:
        self.conn, child = ctx.Pipe()
        self.process: BaseProcess = ctx.Process(
            target=_worker_main, args=(child,), name="causalsplat-batch-worker", daemon=True
        )
        self.process.start()
        child.close()
        self.task: SceneTask | None = None
        self.attempt = 0
        self.since = 0.0

    def give(self, task: SceneTask, attempt: int) -> None:
        self.task, self.attempt, self.since = task, attempt, time.perf_counter()
        self.conn.send((task, attempt))

    def stop(self) -> None:
        if self.process.is_alive():
            with suppress(OSError):
                self.conn.send(None)
            self.process.join(timeout=5)
        if self.process.is_alive():
            self.process.kill()
            self.process.join()
        self.conn.close()


def run_local(tasks: list[SceneTask], workers: int, retries: int, events: _Events) -> None:
    """Build ``tasks`` on ``workers`` processes; each outcome goes to ``events``."""
    ctx = mp.get_context("spawn")
    queue: deque[tuple[SceneTask, int]] = deque((t, 1) for t in tasks)
    threads = tasks[0].config.raster.threads if tasks else None
    pool: list[_Worker] = []
    try:
        with _thread_environment(threads):
            pool = [_Worker(ctx) for _ in range(min(workers, len(tasks)))]
        while queue or any(w.task is not None for w in pool):
            for worker in pool:
                if worker.task is None and queue:
                    task, attempt = queue.popleft()
                    worker.give(task, attempt)
                    events.started(task, attempt, f"worker pid {worker.process.pid}")
            busy = [w for w in pool if w.task is not None]
            ready = set(wait([w.conn for w in busy] + [w.process.sentinel for w in pool]))
            for worker in pool:
                outcome, retry = _collect(worker, ready)
                if outcome is None:
                    continue
                assert worker.task is not None
                task, worker.task = worker.task, None
                if outcome.status == "failed" and retry and outcome.attempts <= retries:
                    events.retry(task, outcome)
                    queue.append((task, outcome.attempts + 1))
                else:
                    events.finished(task, outcome)
            dead = [w for w in pool if w.task is None and not w.process.is_alive()]
            for worker in dead:  # replaced while there is work for it
                worker.stop()
                pool.remove(worker)
                if queue and len(pool) < workers:
                    with _thread_environment(threads):
                        pool.append(_Worker(ctx))
    finally:
        for worker in pool:
            worker.stop()


def _collect(worker: _Worker, ready: Collection[object]) -> tuple[SceneOutcome | None, bool]:
    """The outcome ``worker`` sent, or the failure of its scene if it died; ``(None, _)``
    when it is still at work (or idle and alive)."""
    if worker.task is None:
        return None, False
    if worker.conn in ready:
        try:
            outcome, retry = worker.conn.recv()
            return outcome, retry
        except (EOFError, OSError):
            pass
    elif worker.process.sentinel not in ready:
        return None, False
    worker.process.join()
    return (
        SceneOutcome(
            worker.task.scene_id,
            worker.task.folder,
            "failed",
            attempts=worker.attempt,
            seconds=time.perf_counter() - worker.since,
            error=f"the worker process died ({_exit_reason(worker.process.exitcode)}); "
            "nothing of the scene was stored",
        ),
        True,
    )


def _exit_reason(code: int | None) -> str:
    """How a worker process ended, from its exit code.

    >>> _exit_reason(-9), _exit_reason(3)
    ('killed by SIGKILL', 'exit status 3')
    """
    if code is not None and code < 0:
        try:
            return f"killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"killed by signal {-code}"
    return f"exit status {code}"


@contextmanager
def _thread_environment(threads: int | None) -> Iterator[None]:
    """The numerical libraries' thread variables set to ``threads`` (those not already
    set) while workers are started: a spawned process takes the environment of its start."""
    if threads is None:
        yield
        return
    added = [name for name in THREAD_VARIABLES if name not in os.environ]
    for name in added:
        os.environ[name] = str(threads)
    try:
        yield
    finally:
        for name in added:
            os.environ.pop(name, None)
