"""Building many scene folders into one store: resumable, in worker processes or on Ray.

:func:`build_many` builds every folder into the store at ``store_url`` and returns a
:class:`BatchReport` of one :class:`SceneOutcome` per folder. Each scene is built and
saved by a worker (a process of a local pool, or a Ray task) that opens the store itself
and writes the scene in one transaction (``graph_store`` saves are atomic), so a worker
killed at any point leaves nothing of its scene behind.

Resuming: a folder whose scene is already stored with the same input file hashes and
the same result config (the ``provenance`` and ``config_hash`` a build records) is
skipped, so running the same batch again after a crash builds only what is missing.
What happens to a stored scene whose inputs or config changed is ``if_exists``:

``skip``     (default) the scene fails with an error that says so; nothing is replaced;
``replace``  it is rebuilt and replaced (in one transaction); unchanged scenes are skipped;
``rebuild``  every scene is rebuilt and replaced, changed or not.

A scene that fails is tried again ``retries`` times, except when the failure is certain
to repeat (a malformed folder, a build that finds nothing to build from, a changed stored
scene under ``skip``). A worker process that dies (killed, out of memory) fails its
scene's attempt; the pool starts a new worker and goes on.

Per-scene options are those of ``causalsplat build`` (the ``config``). Unless the config
sets them, each scene's threads default to the cores divided by the workers, and its
views' memory budget to a quarter of the RAM divided by the workers, so that ``workers``
scenes side by side use the machine as one build would.
"""

from __future__ import annotations

import dataclasses
import json
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any, Literal

from causalsplat.build.config import BuildConfig, _physical_memory
from causalsplat.build.pipeline import scene_id_of
from causalsplat.errors import CausalSplatError
from graph_store import as_url

Status = Literal["built", "skipped", "failed"]
BatchIfExists = Literal["skip", "replace", "rebuild"]
IF_EXISTS: tuple[str, ...] = ("skip", "replace", "rebuild")
#: Views' memory budget of a Ray task when the config sets none (MiB): the driver cannot
#: know the memory of the node a task lands on.
RAY_DEFAULT_BUDGET_MIB = 2048
#: RAM per local worker that the default number of workers keeps (MiB).
MIB_PER_WORKER = 4096


class BatchError(CausalSplatError):
    """A batch cannot start: no folders, a folder that is not there, two folders with one
    scene id, a store the workers cannot reach; the message names the problem."""


@dataclass(frozen=True, slots=True)
class SceneOutcome:
    """What became of one folder of a batch.

    Attributes:
        scene_id: the id the scene is (or would have been) stored under.
        folder: the scene folder, absolute.
        status: ``built``, ``skipped`` (already stored with the same inputs) or ``failed``.
        attempts: attempts made (the last one built, skipped or failed the scene).
        seconds: wall seconds of the last attempt (the build and the save).
        peak_rss_mib: peak resident memory of the last attempt's worker, MiB (0 unknown).
        entities, relations: counts of the stored scene (0 unless built).
        error: one line, why it failed (``None`` unless failed).
        warnings: the build's warnings (see ``causalsplat build``).
    """

    scene_id: str
    folder: str
    status: Status
    attempts: int = 1
    seconds: float = 0.0
    peak_rss_mib: float = 0.0
    entities: int = 0
    relations: int = 0
    error: str | None = None
    warnings: tuple[str, ...] = ()

    def to_json(self) -> dict[str, Any]:
        return {
            "scene_id": self.scene_id,
            "folder": self.folder,
            "status": self.status,
            "attempts": self.attempts,
            "seconds": round(self.seconds, 3),
            "peak_rss_mib": round(self.peak_rss_mib, 1),
            "entities": self.entities,
            "relations": self.relations,
            "error": self.error,
            "warnings": list(self.warnings),
        }


@dataclass(frozen=True, slots=True)
class BatchReport:
    """The outcome of :func:`build_many`: one :class:`SceneOutcome` per folder, in the
    order the folders were given, and the batch's wall time.

    >>> r = BatchReport((SceneOutcome("a", "/d/a", "built", seconds=30.0),
    ...                  SceneOutcome("b", "/d/b", "skipped")),
    ...                 seconds=36.0, workers=2, engine="local", store="sqlite:///s.db")
    >>> r.built, r.skipped, r.failed, r.scenes_per_hour
    (1, 1, 0, 100.0)
    """

    outcomes: tuple[SceneOutcome, ...]
    seconds: float
    workers: int
    engine: Literal["local", "ray"]
    store: str

    def count(self, status: Status) -> int:
        return sum(o.status == status for o in self.outcomes)

    @property
    def built(self) -> int:
        return self.count("built")

    @property
    def skipped(self) -> int:
        return self.count("skipped")

    @property
    def failed(self) -> int:
        return self.count("failed")

    @property
    def scenes_per_hour(self) -> float:
        """Scenes built per hour of the batch's wall time (skipped ones not counted)."""
        return 3600.0 * self.built / self.seconds if self.seconds > 0 else 0.0

    def summary_json(self) -> dict[str, Any]:
        return {
            "scenes": len(self.outcomes),
            "built": self.built,
            "skipped": self.skipped,
            "failed": self.failed,
            "seconds": round(self.seconds, 3),
            "scenes_per_hour": round(self.scenes_per_hour, 2),
            "peak_rss_mib": round(max((o.peak_rss_mib for o in self.outcomes), default=0.0), 1),
            "workers": self.workers,
            "engine": self.engine,
            "store": self.store,
        }

    def to_json(self) -> dict[str, Any]:
        return {**self.summary_json(), "outcomes": [o.to_json() for o in self.outcomes]}


@dataclass(frozen=True, slots=True)
class SceneTask:
    """One folder to build, as a worker receives it (picklable)."""

    index: int
    scene_id: str
    folder: str
    store_url: str
    config: BuildConfig
    if_exists: BatchIfExists
    cache_dir: str | bool | None


#: ``progress(line)`` receives the batch's progress lines (one event each, no newline).
Progress = Callable[[str], None]


#: Seconds to wait for a cluster's address to accept a connection before ``ray.init``.
CONNECT_TIMEOUT_S = 5.0


def check_ray_address(address: str, timeout: float = CONNECT_TIMEOUT_S) -> None:
    """Raise :class:`BatchError` when ``address`` (``host:port`` or ``ray://host:port``)
    accepts no TCP connection within ``timeout`` seconds: ``ray.init`` would keep trying
    for minutes. ``local`` and ``auto`` (Ray finds the cluster itself) are not checked."""
    import socket

    if address in ("local", "auto"):
        return
    where = address.removeprefix("ray://")
    host, sep, port = where.rpartition(":")
    if not sep or not port.isdigit() or not host:
        raise BatchError(f"--ray {address!r}: expected local, auto, HOST:PORT or ray://HOST:PORT")
    try:
        socket.create_connection((host.strip("[]"), int(port)), timeout=timeout).close()
    except OSError as exc:
        raise BatchError(
            f"--ray {address}: nothing answers at {host}:{port} ({exc.strerror or exc}); "
            "start a cluster there (ray start --head) or use --ray local"
        ) from exc


def build_many(
    folders: Sequence[str | Path],
    store_url: str,
    *,
    workers: int | None = None,
    ray_address: str | None = None,
    config: BuildConfig | None = None,
    if_exists: BatchIfExists = "skip",
    retries: int = 1,
    cache_dir: str | Path | bool | None = True,
    report_path: str | Path | None = None,
    progress: Progress | None = None,
) -> BatchReport:
    """Build every scene folder into the store at ``store_url`` (module docstring).

    Args:
        folders: scene folders (DESIGN §9); each scene's id is derived as ``build`` does
            (the ``scene_id`` of its ``queries.json`` or ``objects.json``, else the
            folder's name).
        store_url: a SQLite file or PostgreSQL URL every worker can reach.
        workers: scenes built at once (default: local, :func:`default_workers`; Ray, as
            many as the cluster's CPUs let run).
        ray_address: run each scene as a Ray task on this cluster (``"local"``: start one
            on this machine; ``"auto"``: the one this machine belongs to); ``None``: a
            local pool of worker processes.
        config: the build options of every scene (threads and memory budget are per
            scene; their defaults are shared out between the workers).
        if_exists: what to do with stored scenes (module docstring).
        retries: further attempts of a failed scene.
        cache_dir: the stage cache (as for ``build``; shared by the workers).
        report_path: JSON lines, one per scene as it ends, then ``{"summary": ...}``.
        progress: receives one line per event (a scene started, built, skipped, failed).

    Raises:
        BatchError: before anything runs (see the class).
        MissingDependencyError: ``ray_address`` given and Ray not installed.
    """
    if if_exists not in IF_EXISTS:
        raise BatchError(f"if_exists must be one of {', '.join(IF_EXISTS)}, got {if_exists!r}")
    if isinstance(retries, bool) or not isinstance(retries, int) or retries < 0:
        raise BatchError(f"retries must be a non-negative integer, got {retries!r}")
    if workers is not None and (isinstance(workers, bool) or workers < 1):
        raise BatchError(f"workers must be a positive integer, got {workers!r}")
    config = config or BuildConfig()
    paths = _check_folders(folders)
    ids = plan_scene_ids(paths)
    if ray_address is not None:
        check_ray_address(ray_address)  # before the store is touched
    store_url = str(as_url(store_url))
    store = _prepare_store(store_url)
    cores = _cores()
    if ray_address is None:
        workers = min(workers or default_workers(cores), len(paths))
        config = per_worker_config(config, workers, cores)
    else:
        config = per_task_config(config)
    cache = str(cache_dir) if isinstance(cache_dir, Path) else cache_dir
    tasks = [
        SceneTask(i, sid, str(path), store_url, config, if_exists, cache)
        for i, (sid, path) in enumerate(zip(ids, paths))
    ]
    start = time.perf_counter()
    with _Events(len(tasks), retries, report_path, progress) as events:
        threads = config.raster.threads or 1
        events.line(
            f"[batch] {len(tasks)} scenes into {store}, "
            + (f"{workers} worker(s)" if ray_address is None else f"Ray at {ray_address}")
            + f", {threads} thread(s) and {config.memory_budget_mib} MiB of views per scene"
        )
        if ray_address is None:
            from causalsplat.build._batch_local import run_local

            assert workers is not None
            run_local(tasks, workers, retries, events)
            engine: Literal["local", "ray"] = "local"
        else:
            from causalsplat.build._batch_ray import run_ray

            workers = run_ray(
                tasks, ray_address, workers, retries, events, sqlite=_is_sqlite(store_url)
            )
            engine = "ray"
        report = BatchReport(
            tuple(events.outcomes[t.index] for t in tasks),
            time.perf_counter() - start,
            workers,
            engine,
            store,
        )
        events.summary(report)
    return report


def plan_scene_ids(paths: Sequence[Path]) -> list[str]:
    """The scene id of each folder, as ``build`` derives it; raises :class:`BatchError`
    when two folders give one id (naming both), before anything is built."""
    ids = [scene_id_of(p) for p in paths]
    first: dict[str, Path] = {}
    for sid, path in zip(ids, paths):
        if sid in first:
            raise BatchError(
                f"scene id {sid!r} comes from two folders, {first[sid]} and {path}; a batch "
                "stores each folder under its own id (rename a folder, or set scene_id in "
                "its queries.json)"
            )
        first[sid] = path
    return ids


def per_worker_config(config: BuildConfig, workers: int, cores: int) -> BuildConfig:
    """``config`` with the threads and views' memory budget it leaves unset shared out
    between ``workers`` scenes built at once on ``cores`` cores.

    >>> c = per_worker_config(BuildConfig(memory_budget_mib=4000), 2, 2)
    >>> c.raster.threads, c.memory_budget_mib
    (1, 4000)
    """
    if config.raster.threads is None:
        raster = dataclasses.replace(config.raster, threads=max(1, cores // workers))
        config = dataclasses.replace(config, raster=raster)
    if config.memory_budget_mib is None:
        budget = _physical_memory() // 4 // workers // 2**20
        config = dataclasses.replace(config, memory_budget_mib=int(budget))
    return config


def default_workers(cores: int) -> int:
    """Local workers by default: one per core, at most one per :data:`MIB_PER_WORKER` of
    RAM (a build holds the interpreter, torch and the scene's per-Gaussian arrays besides
    its views' budget)."""
    return max(1, min(cores, _physical_memory() // (MIB_PER_WORKER * 2**20)))


def per_task_config(config: BuildConfig) -> BuildConfig:
    """``config`` for a Ray task: one thread and :data:`RAY_DEFAULT_BUDGET_MIB` of views
    unless it says otherwise (the driver does not know the nodes the tasks land on)."""
    if config.raster.threads is None:
        config = dataclasses.replace(config, raster=dataclasses.replace(config.raster, threads=1))
    if config.memory_budget_mib is None:
        config = dataclasses.replace(config, memory_budget_mib=RAY_DEFAULT_BUDGET_MIB)
    return config


def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def _check_folders(folders: Sequence[str | Path]) -> list[Path]:
    if isinstance(folders, str | Path) or not folders:
        raise BatchError("build_many needs a list of one or more scene folders")
    paths = [Path(f).absolute() for f in folders]
    for path in paths:
        if not path.is_dir():
            what = "is not a folder" if path.exists() else "does not exist"
            raise BatchError(f"{path}: {what}; build_many takes scene folders (DESIGN §9)")
    return paths


def _is_sqlite(url: str) -> bool:
    return url.split(":", 1)[0].split("+", 1)[0] == "sqlite"


def _prepare_store(url: str) -> str:
    """Create the store (schema) once before the workers open it; its URL for messages."""
    from graph_store import open_store

    if _is_sqlite(url):
        from graph_store._engine import parse_url

        database = parse_url(url).database
        if database in (None, "", ":memory:") or database.startswith("file:"):
            raise BatchError(
                f"{url}: the workers of a batch each open the store, so it must be a file "
                "(sqlite:///PATH) or a PostgreSQL server, not an in-memory database"
            )
    with open_store(url) as store:
        return store.initialise().url


class _Events:
    """The batch's progress lines, its report file and the outcome of each scene."""

    def __init__(
        self,
        total: int,
        retries: int,
        report_path: str | Path | None,
        progress: Progress | None,
    ) -> None:
        self.total, self.retries, self.progress = total, retries, progress
        self.outcomes: dict[int, SceneOutcome] = {}
        self.path = None if report_path is None else Path(report_path)
        self.file: IO[str] | None = None

    def __enter__(self) -> _Events:
        if self.path is not None:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self.file = self.path.open("w", encoding="utf-8")
        return self

    def __exit__(self, *_exc: object) -> None:
        if self.file is not None:
            self.file.close()

    def line(self, text: str) -> None:
        if self.progress is not None:
            self.progress(text)

    def started(self, task: SceneTask, attempt: int, where: str) -> None:
        self.line(f"[start] {task.scene_id} on {where} (attempt {attempt} of {1 + self.retries})")

    def retry(self, task: SceneTask, outcome: SceneOutcome) -> None:
        self.line(
            f"[retry] {task.scene_id} failed (attempt {outcome.attempts} of "
            f"{1 + self.retries}): {outcome.error}"
        )

    def finished(self, task: SceneTask, outcome: SceneOutcome) -> None:
        self.outcomes[task.index] = outcome
        head = f"[{len(self.outcomes)}/{self.total}] {outcome.scene_id}"
        if outcome.status == "built":
            self.line(
                f"{head} built in {outcome.seconds:.1f} s (peak {_size(outcome.peak_rss_mib)}, "
                f"{outcome.entities} entities, {outcome.relations} relations)"
            )
        elif outcome.status == "skipped":
            self.line(f"{head} skipped: stored with the same inputs and config")
        else:
            after = f" after {outcome.attempts} attempts" if outcome.attempts > 1 else ""
            self.line(f"{head} failed{after}: {outcome.error}")
        if self.file is not None:
            self.file.write(json.dumps(outcome.to_json(), ensure_ascii=False) + "\n")
            self.file.flush()

    def summary(self, report: BatchReport) -> None:
        if self.file is not None:
            self.file.write(json.dumps({"summary": report.summary_json()}) + "\n")
            self.file.flush()


def _size(mib: float) -> str:
    """A size in MiB for a progress line.

    >>> _size(1234.0), _size(80.4)
    ('1.2 GiB', '80 MiB')
    """
    return f"{mib / 1024:.1f} GiB" if mib >= 1024 else f"{mib:.0f} MiB"
