"""Bad input through the real command line: one typed error line, a non-zero exit, no
traceback, and the store and the working folder exactly as they were.

Each row of :data:`CASES` makes its input in a fresh folder that holds a good store
(``good.db``, the kitchen scene), runs one command and names a part of the one line it
must print. Files in the folder are hashed before and after: a bad input changes none,
creates none.
"""

from __future__ import annotations

import hashlib
import json
import os
import resource
import subprocess
import sys
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from tests.causalsplat.test_objects import KITCHEN
from tests.conftest import COMMAND_TIMEOUT_S, REPO_ROOT

CARTESIAN = (
    "SELECT ?a ?b ?c ?d ?e WHERE { ?a ?p ?x . ?b ?q ?y . ?c ?r ?z . ?d ?s ?w . ?e ?t ?v }"
    " ORDER BY ?a ?b ?c ?d ?e"
)


@dataclass(frozen=True)
class Case:
    name: str
    make: Callable[[Path], list[str]]  # writes its input under the folder, returns argv
    message: str  # a part of the one error line


def _write(path: Path, data: bytes | str) -> Path:
    path.write_bytes(data if isinstance(data, bytes) else data.encode())
    return path


def _corrupt(folder: Path) -> str:
    _write(folder / "corrupt.db", b"this is not a database\n" * 100)
    return f"sqlite:///{folder / 'corrupt.db'}"


def _truncated(folder: Path) -> str:
    _write(folder / "half.db", (folder / "good.db").read_bytes()[:5000])
    return f"sqlite:///{folder / 'half.db'}"


def _deep(folder: Path) -> str:
    return str(_write(folder / "deep.json", '{"a":' * 100_000 + "1" + "}" * 100_000))


def _typo(folder: Path) -> str:
    return f"sqlite:///{folder / 'typo.db'}"


def _good(folder: Path) -> str:
    return f"sqlite:///{folder / 'good.db'}"


def _tiny(folder: Path) -> Path:
    """A synthetic tiny scene folder under ``folder`` (cameras as COLMAP text)."""
    from causalsplat.synth import synth_scene

    synth_scene("tiny", 0, folder / "tiny")
    return folder / "tiny"


def _masks_as_json(folder: Path) -> str:
    scene = _tiny(folder)
    first = sorted((scene / "masks").glob("*.npz"))[0]
    first.unlink()
    _write(first.with_suffix(".json"), '[{"segmentation": {"size": [4, 4], "counts": "0"}}]')
    return str(scene)


def _huge_focal(folder: Path) -> str:
    scene = _tiny(folder)
    cameras = next(scene.rglob("cameras.txt"))
    lines = cameras.read_text().splitlines()
    i = next(k for k, line in enumerate(lines) if line and not line.startswith("#"))
    f = lines[i].split()
    lines[i] = " ".join([*f[:4], "1e308", *f[5:]])
    cameras.write_text("\n".join(lines) + "\n")
    return str(scene)


def _program_file(folder: Path, program: dict[str, object]) -> str:
    return str(_write(folder / "program.json", json.dumps(program)))


SAME_POINT = {
    "query_type": "spatial",
    "steps": [
        {"op": "scene"},
        {"op": "filter_category", "inputs": [0], "value": "sink"},
        {"op": "relate", "inputs": [0, 1], "relation": "left_of",
         "viewpoint": {"eye": [1, 2, 0], "target": [1, 2, 5]}},
    ],
    "answer_step": 2,
}  # fmt: skip

SINKS = {
    "query_type": "spatial",
    "steps": [{"op": "scene"}, {"op": "filter_category", "inputs": [0], "value": "sink"}],
    "answer_step": 1,
}

ONE_QUERY = json.dumps({"scene_id": "kitchen", "queries": [{"text": "a sink", "targets": []}]})

CASES = [
    Case("scenes: a file that is not a database",
         lambda f: ["scenes", "--db", _corrupt(f)], "file is not a database"),
    Case("scenes: a truncated store",
         lambda f: ["scenes", "--db", _truncated(f)], "cannot open the store"),
    Case("db upgrade: a file that is not a database",
         lambda f: ["db", "upgrade", "--db", _corrupt(f)], "cannot migrate the store"),
    Case("db current: a file that is not a database",
         lambda f: ["db", "current", "--db", _corrupt(f)], "file is not a database"),
    Case("scenes: a store that does not exist is not created",
         lambda f: ["scenes", "--db", f"sqlite:///{f / 'typo.db'}"], "no store at"),
    Case("sparql: a store that does not exist is not created",
         lambda f: ["sparql", "ASK {}", "--db", f"sqlite:///{f / 'typo.db'}"], "no store at"),
    Case("db current: a store that does not exist is not created",
         lambda f: ["db", "current", "--db", f"sqlite:///{f / 'typo.db'}"], "no store at"),
    Case("ask: a store that does not exist is not created",
         lambda f: ["ask", "a chair", "--scene", "kitchen", "--db", _typo(f)],
         "typo.db does not exist"),
    Case("query: a store that does not exist is not created",
         lambda f: ["query", _program_file(f, SINKS), "--scene", "kitchen",
                    "--db", _typo(f)], "typo.db does not exist"),
    Case("eval: a store that does not exist is not created",
         lambda f: ["eval", str(_write(f / "q.json", ONE_QUERY)),
                    "--scene", "kitchen", "--db", _typo(f)], "typo.db does not exist"),
    Case("export: a store that does not exist is not created",
         lambda f: ["export", "--db", _typo(f)], "typo.db does not exist"),
    Case("export ply: a store that does not exist is not created",
         lambda f: ["export", "--scene", "kitchen", "--format", "ply", "-o", str(f / "o.ply"),
                    "--db", _typo(f)], "typo.db does not exist"),
    Case("export png, --db before the command: a store that does not exist is not created",
         lambda f: ["--db", _typo(f), "export", "--scene", "kitchen", "--format", "png",
                    "-o", str(f / "o.png")], "typo.db does not exist"),
    Case("export --embed-labels with another format",
         lambda f: ["export", "--format", "turtle", "--embed-labels", "--db", _good(f)],
         "--embed-labels is an option of --format ply"),
    Case("export --overlay with another format",
         lambda f: ["export", "--scene", "kitchen", "--format", "png", "--overlay",
                    "-o", str(f / "o.png"), "--db", _good(f)], "--overlay is an option of"),
    Case("an empty --db", lambda f: ["scenes", "--db", ""], "database URL is empty"),
    Case("ask: an empty instruction",
         lambda f: ["ask", "", "--scene", "kitchen", "--db", _good(f)], "has no words"),
    Case("ask: control characters only",
         lambda f: ["ask", "\x01\x02", "--scene", "kitchen", "--db", _good(f)], "has no words"),
    Case("sparql --timeout nan",
         lambda f: ["sparql", "ASK {}", "--timeout", "nan", "--db", _good(f)],
         "--timeout must be in [0.001, 86400] seconds, got 'nan'"),
    Case("sparql --timeout inf",
         lambda f: ["sparql", "ASK {}", "--timeout", "inf", "--db", _good(f)],
         "--timeout must be in [0.001, 86400] seconds, got 'inf'"),
    Case("serve --timeout inf",
         lambda f: ["serve", "--timeout", "inf", "--port", "0", "--db", _good(f)],
         "--timeout must be in [0.001, 86400] seconds, got 'inf'"),
    Case("ask --timeout nan (the VLM's)",
         lambda f: ["ask", "a sink", "--reasoner", "vlm", "--timeout", "nan", "--scene",
                    "kitchen", "--db", _good(f)], "--timeout must be in"),
    Case("sparql: a query nested 5,000 levels deep",
         lambda f: ["sparql", "SELECT * WHERE " + "{" * 5000 + "?s ?p ?o" + "}" * 5000,
                    "--db", _good(f)], "nests groups 5000 levels deep; at most 64"),
    Case("sparql: a query nested past the parser's reach",
         lambda f: ["sparql", "SELECT * WHERE " + "{" * 60 + "?s ?p ?o" + "}" * 60,
                    "--db", _good(f)], "nested too deeply to be read"),
    Case("sparql --file: a binary file",
         lambda f: ["sparql", "--file", str(_write(f / "q.rq", bytes(range(128, 256)))),
                    "--db", _good(f)], "not UTF-8 text (byte 0 is 0x80)"),
    Case("sparql: one variable bound twice",
         lambda f: ["sparql", "SELECT ?e WHERE { ?e csg:category ?c }", "--bind", "c=sink",
                    "--bind", "c=towel", "--db", _good(f)], "--bind c is given twice"),
    Case("ingest-objects: no objects",
         lambda f: ["ingest-objects", str(_write(f / "none.json", '{"objects": []}')),
                    "--db", _typo(f)], "objects: is empty"),
    Case("ingest-objects: a control character in --scene",
         lambda f: ["ingest-objects", str(_write(f / "k.json", json.dumps(KITCHEN))),
                    "--scene", "a\x01b", "--db", _good(f)], "contains the control character"),
    Case("eval: no queries",
         lambda f: ["eval", str(_write(f / "q.json", '{"queries": []}')), "--scene", "kitchen",
                    "--db", _good(f)], "the 'queries' list is empty"),
    Case("build --config: a 5,000-digit integer",
         lambda f: ["build", str(f), "--config",
                    str(_write(f / "c.json", '{"field": {"iterations": 1' + "0" * 5000 + "}}")),
                    "--db", _good(f)], "Exceeds the limit (4300 digits)"),
    Case("build --config: a trillion training steps",
         lambda f: ["build", str(f), "--config",
                    str(_write(f / "c.json", '{"field": {"iterations": 1000000000000}}')),
                    "--db", _good(f)], "iterations must be an integer in [0, 1000000]"),
    Case("build --config: a key given twice",
         lambda f: ["build", str(f), "--config",
                    str(_write(f / "c.json", '{"seed": 1, "seed": 2}')), "--db", _good(f)],
         "the key 'seed' appears twice"),
    Case("synth --noise 1e300",
         lambda f: ["synth", "--size", "tiny", "--noise", "1e300", "-o", str(f / "s")],
         "noise_strength must be in [0, 20], got 1e+300"),
    Case("ask --reasoner vlm --base-url '::::'",
         lambda f: ["ask", "a sink", "--reasoner", "vlm", "--base-url", "::::", "--model", "m",
                    "--scene", "kitchen", "--db", _good(f)], "base URL must be http(s)://"),
    Case("ask --replay: a binary file",
         lambda f: ["ask", "a sink", "--reasoner", "vlm", "--model", "m", "--replay",
                    str(_write(f / "r.jsonl", bytes(range(128, 256)))), "--scene", "kitchen",
                    "--db", _good(f)], "not a recording: not UTF-8 text"),
    Case("masks convert --size beyond any camera",
         lambda f: ["masks", "convert", str(f), "-o", str(f / "m"), "--size", "100000x100000"],
         "each in [1, 16384], got '100000x100000'"),
    Case("export -o a file in a folder that cannot be written",
         lambda f: ["export", "-o", "/proc/x.ttl", "--db", _good(f)], ": /proc/x.ttl"),
    Case("sparql --bind a name the query does not use",
         lambda f: ["sparql", "SELECT ?e WHERE { ?e a ?t }", "--bind", "anchr=table",
                    "--db", _good(f)], "binding ?anchr: the query has no such variable"),
    Case("query: a binary file",
         lambda f: ["query", str(_write(f / "prog.bin", bytes(range(256)) * 8)),
                    "--scene", "kitchen", "--db", _good(f)], "not binary data"),
    Case("query: a viewpoint whose eye is its target",
         lambda f: ["query", _program_file(f, SAME_POINT), "--scene", "kitchen",
                    "--db", _good(f)], "eye and target must be at least"),
    Case("ingest-objects: JSON nested 100,000 deep",
         lambda f: ["ingest-objects", _deep(f), "--db", _good(f)], "nested too deeply"),
    Case("eval: JSON nested 100,000 deep",
         lambda f: ["eval", _deep(f), "--scene", "kitchen", "--db", _good(f)],
         "nested too deeply"),
    Case("export -o an existing folder",
         lambda f: ["export", "-o", str(f), "--db", _good(f)], "the output is a folder"),
    Case("build: a view's masks as SAM JSON where the .npz belongs",
         lambda f: ["build", _masks_as_json(f), "--no-cache", "--db", _good(f)],
         "a build reads each view's masks from masks/<image stem>.npz"),
    Case("build: cameras.txt with fx=1e308",
         lambda f: ["build", _huge_focal(f), "--no-cache", "--db", _good(f)],
         "out of range: fx, fy must be in (0,"),
    Case("build-many --ray at an address where nothing listens",
         lambda f: ["build-many", str(_tiny(f)), "--ray", "127.0.0.1:9", "--db",
                    f"sqlite:///{f / 'new.db'}"], "nothing answers at 127.0.0.1:9"),
]  # fmt: skip


def _run(argv: list[str], cwd: Path, **kwargs: object) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "causalsplat", *argv],
        capture_output=True,
        text=True,
        cwd=cwd,
        env={**os.environ, "PYTHONPATH": str(REPO_ROOT)},
        timeout=COMMAND_TIMEOUT_S,
        **kwargs,  # type: ignore[arg-type]
    )


def _snapshot(folder: Path) -> dict[str, str]:
    return {
        str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(folder.rglob("*"))
        if p.is_file()
    }


@pytest.fixture(scope="module")
def good_store(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("good")
    objects = _write(folder / "kitchen.json", json.dumps(KITCHEN))
    proc = _run(["ingest-objects", str(objects), "--db", f"sqlite:///{folder / 'good.db'}"],
                folder)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    return folder / "good.db"


def _assert_one_line(proc: subprocess.CompletedProcess[str], message: str) -> None:
    assert proc.returncode != 0, proc.stdout
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith("causalsplat: error: "), lines[0]
    assert message in lines[0], lines[0]


@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_bad_input_is_one_line_and_changes_nothing(
    case: Case, good_store: Path, tmp_path: Path
) -> None:
    (tmp_path / "good.db").write_bytes(good_store.read_bytes())
    argv = case.make(tmp_path)
    before = _snapshot(tmp_path)
    proc = _run(argv, tmp_path)
    _assert_one_line(proc, case.message)
    assert _snapshot(tmp_path) == before


def test_a_cartesian_sparql_query_under_a_memory_cap_ends_in_an_error(
    good_store: Path, tmp_path: Path
) -> None:
    """The query's worker is stopped by its limits (time or memory), the process is not:
    under a 1 GB address-space limit the command still prints one error line."""
    cap = 1 << 30

    def limit() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (cap, cap))

    db = f"sqlite:///{good_store}"
    proc = _run(["sparql", CARTESIAN, "--timeout", "5", "--db", db], tmp_path,
                preexec_fn=limit)  # fmt: skip
    _assert_one_line(proc, "the SPARQL query")
    assert "did not finish within 5.0 s" in proc.stderr or "ran out of memory" in proc.stderr


@pytest.fixture
def read_only_mount(tmp_path: Path, good_store: Path) -> Iterator[Path]:
    """A tmpfs holding the good store, remounted read-only (needs root; else skipped)."""
    mount = tmp_path / "ro"
    mount.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=16m", "tmpfs", str(mount)],
                      capture_output=True).returncode != 0:  # fmt: skip
        pytest.skip("cannot mount a filesystem here (not root, or no CAP_SYS_ADMIN)")
    try:
        (mount / "good.db").write_bytes(good_store.read_bytes())
        subprocess.run(["mount", "-o", "remount,ro", str(mount)], check=True)
        yield mount / "good.db"
    finally:
        subprocess.run(["umount", str(mount)], check=False)


def test_a_store_on_a_read_only_filesystem_is_read_not_written(
    read_only_mount: Path, tmp_path: Path
) -> None:
    db = f"sqlite:///{read_only_mount}"
    before = hashlib.sha256(read_only_mount.read_bytes()).hexdigest()
    scenes = _run(["scenes", "--json", "--db", db], tmp_path)
    assert scenes.returncode == 0, scenes.stderr
    assert [s["scene_id"] for s in json.loads(scenes.stdout)] == ["kitchen"]
    asked = _run(["ask", "the sink", "--scene", "kitchen", "--json", "--db", db], tmp_path)
    assert asked.returncode == 0, asked.stderr
    assert [e["category"] for e in json.loads(asked.stdout)["entities"]] == ["sink"]
    sparql = _run(["sparql", "ASK { ?a csg:near ?b }", "--json", "--db", db], tmp_path)
    assert sparql.returncode == 0 and json.loads(sparql.stdout)["boolean"] is True
    objects = _write(tmp_path / "more.json", json.dumps({**KITCHEN, "scene_id": "more"}))
    _assert_one_line(_run(["ingest-objects", str(objects), "--db", db], tmp_path),
                     "cannot open the store")  # fmt: skip
    assert hashlib.sha256(read_only_mount.read_bytes()).hexdigest() == before
    assert sorted(p.name for p in read_only_mount.parent.iterdir()) == ["good.db"]
