"""One scene of a batch, as a worker runs it: skip it, or build it and save it.

:func:`run_scene` never raises for a failure of the scene: it returns a failed
:class:`~causalsplat.build.batch.SceneOutcome` and whether another attempt could end
otherwise. It runs in a worker process (local pool or Ray task), opens the store itself
and writes the scene in one transaction.
"""

from __future__ import annotations

import time
from typing import Any

from causalsplat.build.batch import SceneOutcome, SceneTask
from causalsplat.build.errors import BuildError, StageError, describe_error
from causalsplat.errors import InputFormatError
from graph_store.types import SceneMeta


class SceneChangedError(BuildError):
    """A stored scene was built from other inputs or options than the folder's now."""


def run_scene(task: SceneTask, attempt: int) -> tuple[SceneOutcome, bool]:
    """Skip, or build and store, ``task``'s scene; returns its outcome and, for a failure,
    whether to try again (``False`` when the failure is certain to repeat)."""
    reset_peak_rss()
    start = time.perf_counter()
    try:
        return _run(task, attempt, start), False
    except (InputFormatError, SceneChangedError) as exc:
        return _failed(task, attempt, start, str(exc)), False
    except BuildError as exc:  # nothing to build from repeats; a stage error may not
        return _failed(task, attempt, start, str(exc)), isinstance(exc, StageError)
    except Exception as exc:  # store errors, memory, a bug: another attempt may pass
        return _failed(task, attempt, start, describe_error(exc)), True


def _run(task: SceneTask, attempt: int, start: float) -> SceneOutcome:
    from causalsplat.build.pipeline import _peak_rss_mib, build_scene
    from graph_store import open_store

    with open_store(task.store_url, create=False) as store:
        if_exists: Any = "fail"
        if store.has_scene(task.scene_id):
            if task.if_exists != "rebuild":
                changed = stored_changes(store.scene_meta(task.scene_id), task)
                if not changed:
                    return SceneOutcome(
                        task.scene_id, task.folder, "skipped", attempts=attempt,
                        seconds=time.perf_counter() - start, peak_rss_mib=_peak_rss_mib(),
                    )  # fmt: skip
                if task.if_exists == "skip":
                    raise SceneChangedError(
                        f"scene {task.scene_id!r} is already stored, built from other "
                        f"{changed} than this batch gives it ({task.folder}); "
                        "--if-exists replace rebuilds it"
                    )
            if_exists = "replace"
        result = build_scene(
            task.folder, scene_id=task.scene_id, config=task.config, cache_dir=task.cache_dir
        )
        store.save_scene(result.graph, if_exists=if_exists, gaussian_labels=result.gaussian_labels)
    return SceneOutcome(
        task.scene_id,
        task.folder,
        "built",
        attempts=attempt,
        seconds=time.perf_counter() - start,
        peak_rss_mib=max((s.peak_rss_mib for s in result.stages), default=0.0),
        entities=len(result.graph.entities),
        relations=len(result.graph.relations),
        warnings=result.warnings,
    )


def stored_changes(meta: SceneMeta, task: SceneTask) -> str | None:
    """What differs between a stored scene and what ``task`` would build (``"inputs"``,
    ``"options"``, ``"inputs and options"``), or ``None`` when the build would store the
    same scene. The folder's path is not compared: a moved folder is the same input."""
    from causalsplat.build.cache import cache_key
    from causalsplat.build.pipeline import scene_input_hashes

    stored = {k: v for k, v in meta.provenance if k != "source_dir"}
    inputs = meta.source != "build" or stored != scene_input_hashes(task.folder, task.config)
    options = meta.config_hash != cache_key(task.config.result_json())
    if inputs and options:
        return "inputs and options"
    return "inputs" if inputs else "options" if options else None


def _failed(task: SceneTask, attempt: int, start: float, error: str) -> SceneOutcome:
    from causalsplat.build.pipeline import _peak_rss_mib

    line = next((part.strip() for part in error.splitlines() if part.strip()), "failed")
    return SceneOutcome(
        task.scene_id, task.folder, "failed", attempts=attempt,
        seconds=time.perf_counter() - start, peak_rss_mib=_peak_rss_mib(), error=line,
    )  # fmt: skip


def reset_peak_rss() -> None:
    """Start this process's peak resident memory (``VmHWM``) again from its current size,
    so a worker that builds one scene after another reports each scene's own peak (Linux;
    elsewhere the peak stays the worker's so far)."""
    try:
        with open("/proc/self/clear_refs", "w", encoding="ascii") as handle:
            handle.write("5")
    except OSError:
        pass
