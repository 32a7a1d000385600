"""Run time of reasoning: ``causalsplat ask`` in a cold process and warm ``scene.ask``.

Cold: a fresh interpreter runs ``causalsplat ask ... --json`` on a persisted scene, timed
from outside (median of ``repeats``), next to two baselines measured in the same run: a
bare ``python -c pass`` and ``python -c "import causalsplat.api"`` (the store layer the
command needs anyway). The child also reports whether torch was imported.

Warm: a scene handle that has answered once answers the same instructions again; each
instruction's time is the median of ``repeats``; the baseline is running the answer's
program on the scene's (already built) reference executor: what an answer would cost if
parsing and planning were free.
"""

from __future__ import annotations

import statistics
import subprocess
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

_CHILD = """
import sys, time
start = time.perf_counter()
from causalsplat.cli import main
sys.argv = ["causalsplat", "ask", {text!r}, "--scene", {scene!r}, "--db", {url!r}, "--json"{extra}]
try:
    main()
except SystemExit as exc:
    if exc.code:
        raise
print("TORCH=" + str("torch" in sys.modules), file=sys.stderr)
"""


@dataclass(frozen=True, slots=True)
class ColdTiming:
    ask_s: float
    python_s: float
    import_s: float
    torch_imported: bool
    ask_cpu_s: float = 0.0


def _run(args: list[str], repeats: int) -> tuple[float, float, str]:
    """Median wall and CPU (user + system) seconds of a child process, and its stderr.

    The child may write and read Python's bytecode cache, as an installed package does
    (pip compiles it at install time), even where ``PYTHONDONTWRITEBYTECODE`` is set here;
    an untimed first run writes it."""
    import os
    import resource

    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    subprocess.run(args, capture_output=True, text=True, check=True, env=env)
    times, cpu = [], []
    err = ""
    for _ in range(repeats):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        start = time.perf_counter()
        proc = subprocess.run(args, capture_output=True, text=True, check=True, env=env)
        times.append(time.perf_counter() - start)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu.append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
        err = proc.stderr
    return statistics.median(times), statistics.median(cpu), err


def cold_ask(
    url: str, scene: str, text: str, *, embeddings: bool | None = False, repeats: int = 5
) -> ColdTiming:
    """Median wall time (and CPU time) of a cold ``causalsplat ask`` and of the two
    baselines; ``embeddings``: ``False`` passes ``--no-embeddings``, ``True``
    ``--embeddings``, ``None`` neither (the default: embeddings when installed)."""
    extra = {False: ', "--no-embeddings"', True: ', "--embeddings"', None: ""}[embeddings]
    code = _CHILD.format(text=text, scene=scene, url=url, extra=extra)
    ask_s, ask_cpu_s, err = _run([sys.executable, "-c", code], repeats)
    python_s, _, _ = _run([sys.executable, "-c", "pass"], repeats)
    import_s, _, _ = _run([sys.executable, "-c", "import causalsplat.api"], repeats)
    return ColdTiming(ask_s, python_s, import_s, "TORCH=True" in err, ask_cpu_s)


@dataclass(frozen=True, slots=True)
class WarmTiming:
    ask_ms: float
    executor_ms: float
    n_queries: int
    n_entities: int


def warm_ask(
    scene: object, texts: Sequence[str], *, repeats: int = 5, **options: object
) -> WarmTiming:
    """Median per-instruction time of a warm ``scene.ask`` and of running its program."""
    from causalsplat.api import Scene

    assert isinstance(scene, Scene)
    answers = [scene.ask(t, **options) for t in texts]  # type: ignore[arg-type]
    ctx = scene._reasoning_context()
    ask, run = [], []
    for text, answer in zip(texts, answers, strict=True):
        samples = []
        for _ in range(repeats):
            start = time.perf_counter()
            scene.ask(text, **options)  # type: ignore[arg-type]
            samples.append(time.perf_counter() - start)
        ask.append(statistics.median(samples))
        samples = []
        for _ in range(repeats):
            start = time.perf_counter()
            ctx.run(answer.program)
            samples.append(time.perf_counter() - start)
        run.append(statistics.median(samples))
    return WarmTiming(
        1000 * statistics.median(ask),
        1000 * statistics.median(run),
        len(texts),
        len(scene.entities),
    )


def persist_scan(url_dir: Path, scan: str) -> str:
    """Ingest one scan's object table into a fresh SQLite store; returns its URL."""
    from causalsplat.api import open_store
    from causalsplat.bench._reasoning_referit import objects_document
    from causalsplat.objects import objects_to_scene_graph, parse_objects

    url = f"sqlite:///{url_dir / f'{scan}.db'}"
    with open_store(url) as store:
        graph = objects_to_scene_graph(parse_objects(objects_document(scan), source=scan))
        store.save_scene(graph, if_exists="replace")
    return url
