"""The Ray engine of a batch: each scene a Ray task that builds and stores it.

Ray schedules the tasks by the resources each declares: ``num_cpus`` (the scene's
threads) and ``memory`` (its views' budget plus the rest of a build, estimated from the
folder's size). The workers open the store themselves and write each scene in one
transaction, so the store's URL must reach the store from every node: a PostgreSQL
server, or a SQLite file when the cluster is this one machine (refused on a cluster of
several nodes). The driver only collects outcomes (``ray.wait``) and resubmits a failed
scene that may pass on another attempt, a task whose worker died among them. Ray is
imported here only, when a batch names a cluster.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from causalsplat.build.batch import BatchError, SceneOutcome, SceneTask
from causalsplat.build.errors import describe_error
from causalsplat.errors import MissingDependencyError

if TYPE_CHECKING:
    from causalsplat.build.batch import _Events

#: Memory of a build besides the views' budget: the interpreter with torch (MiB) ...
BASE_MEMORY_MIB = 1024
#: ... and this many times the size of the folder's PLY and masks (per-Gaussian arrays,
#: masks read, evidence).
INPUT_MEMORY_FACTOR = 4


def _import_ray() -> Any:
    try:
        import ray
    except ImportError as exc:
        raise MissingDependencyError("--ray needs Ray: pip install 'causalsplat[ray]'") from exc
    return ray


def _scene_task(task: SceneTask, attempt: int) -> tuple[SceneOutcome, bool]:
    """The body of a scene's Ray task (runs on a Ray worker)."""
    from causalsplat.build._batch_scene import run_scene

    return run_scene(task, attempt)


def task_memory_bytes(task: SceneTask) -> int:
    """The memory a scene's task declares to Ray: the views' budget, the interpreter and
    :data:`INPUT_MEMORY_FACTOR` times the folder's files."""
    size = sum(p.stat().st_size for p in Path(task.folder).rglob("*") if p.is_file())
    budget = task.config.memory_budget_mib or 0
    return (BASE_MEMORY_MIB + budget) * 2**20 + INPUT_MEMORY_FACTOR * size


def run_ray(
    tasks: list[SceneTask],
    address: str,
    workers: int | None,
    retries: int,
    events: _Events,
    *,
    sqlite: bool,
) -> int:
    """Build ``tasks`` as Ray tasks on the cluster at ``address`` (``"local"`` starts one
    on this machine for the batch); at most ``workers`` at once when given. Returns the
    number of scenes that could run at once (``workers``, else the cluster's CPUs)."""
    ray = _import_ray()
    started = not ray.is_initialized()
    if started:
        if address == "local":
            ray.init(include_dashboard=False, log_to_driver=False)
        else:
            ray.init(address=address, include_dashboard=False, log_to_driver=False)
    try:
        if sqlite and len([n for n in ray.nodes() if n.get("Alive")]) > 1:
            raise BatchError(
                "a SQLite store is one file on one machine and this Ray cluster has several "
                "nodes: use a PostgreSQL store (--db postgresql+psycopg://...) every node reaches"
            )
        threads = tasks[0].config.raster.threads if tasks else None
        return _drive(ray, tasks, workers, retries, events, threads or 1)
    finally:
        if started:
            ray.shutdown()


def _drive(
    ray: Any,
    tasks: list[SceneTask],
    workers: int | None,
    retries: int,
    events: _Events,
    threads: int,
) -> int:
    remote = ray.remote(_scene_task)
    cpus = int(ray.cluster_resources().get("CPU", 1))
    limit = workers or max(1, cpus // threads)
    # A task asking more memory than any node has would wait for ever: ask at most that.
    node_memory = max(int(n["Resources"].get("memory", 0)) for n in ray.nodes() if n.get("Alive"))
    queue = [(t, 1) for t in reversed(tasks)]
    pending: dict[Any, tuple[SceneTask, int]] = {}
    while queue or pending:
        while queue and len(pending) < limit:
            task, attempt = queue.pop()
            ref = remote.options(
                num_cpus=threads, memory=min(task_memory_bytes(task), node_memory), max_retries=0,
                name=f"build {task.scene_id}",
            ).remote(task, attempt)  # fmt: skip
            pending[ref] = (task, attempt)
            events.started(task, attempt, "Ray")
        done, _ = ray.wait(list(pending), num_returns=1)
        task, attempt = pending.pop(done[0])
        try:
            outcome, retry = ray.get(done[0])
        except ray.exceptions.RayError as exc:  # the worker died, the node was lost...
            outcome = SceneOutcome(
                task.scene_id, task.folder, "failed", attempts=attempt,
                error=f"the Ray task failed: {describe_error(exc)}",
            )  # fmt: skip
            retry = True
        if outcome.status == "failed" and retry and attempt <= retries:
            events.retry(task, outcome)
            queue.insert(0, (task, attempt + 1))
        else:
            events.finished(task, outcome)
    return limit
