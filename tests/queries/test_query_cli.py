"""``causalsplat query`` through the real command line."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from graph_store.repository import open_store
from tests.conftest import COMMAND_TIMEOUT_S, REPO_ROOT
from tests.queries.test_query_counterfactual import removal, scene


def run(*args: str, stdin: str | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "causalsplat", *args],
        capture_output=True,
        text=True,
        cwd=REPO_ROOT,
        env={**os.environ},
        input=stdin,
        timeout=COMMAND_TIMEOUT_S,
    )


@pytest.fixture
def db(tmp_path: Path) -> str:
    url = f"sqlite:///{tmp_path / 'store.db'}"
    with open_store(url) as store:
        store.save_scene(scene())
    return url


def test_help() -> None:
    proc = run("query", "--help")
    assert proc.returncode == 0
    assert "--executor" in proc.stdout and "--explain" in proc.stdout


@pytest.mark.parametrize("executor", ["sql", "sparql", "networkx"])
def test_json_answer_is_the_same_on_every_executor(db: str, tmp_path: Path, executor: str) -> None:
    program = tmp_path / "program.json"
    program.write_text(removal(2).to_json())
    proc = run("query", str(program), "--scene", "cf", "--executor", executor, "--db", db, "--json")
    assert proc.returncode == 0, proc.stderr
    doc = json.loads(proc.stdout)
    assert doc["answer"] == [4, 5]
    assert doc["executor"] == executor
    assert [e["category"] for e in doc["entities"]] == ["board", "cup"]
    assert doc["support_paths"] == [
        {"step": 2, "entity": 4, "path": [4, 2]},
        {"step": 2, "entity": 5, "path": [5, 4, 2]},
    ]


def test_text_form_from_stdin_with_explain(db: str) -> None:
    proc = run("query", "-", "--scene", "cf", "--db", db, "--explain", stdin=removal(2).to_text())
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert lines[0] == "query counterfactual"
    assert lines[2] == 'v1 = filter_category(v0, "table")  # 2 entities: 2, 3'
    assert lines[3] == "v2 = fall_if_removed(v1)  # 2 entities: 4, 5"
    assert "# v2: 5 falls: 5 -> 4 -> 2" in lines
    assert lines[-3] == "2 entities"
    assert lines[-1].split()[:2] == ["5", "cup"]


def test_count_and_exists_answers(db: str, tmp_path: Path) -> None:
    program = tmp_path / "count.txt"
    program.write_text(
        'query intrinsic\nv0 = scene()\nv1 = filter_category(v0, "table")\nv2 = count(v1)'
    )
    proc = run("query", str(program), "--scene", "cf", "--db", db)
    assert (proc.returncode, proc.stdout) == (0, "2\n")
    program.write_text("query intrinsic\nv0 = scene()\nv1 = exists(v0)")
    assert run("query", str(program), "--scene", "cf", "--db", db).stdout == "yes\n"


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ('{"query_type": "spatial", "steps": [{"op": "scene"}, {"op": "relate", "inputs": [0, 0]}],'
         ' "answer_step": 1}', "step 1: field 'relation': is required"),
        ("query spatial\nv0 = scene(", "field 'text': line 2"),
    ],
)  # fmt: skip
def test_invalid_programs_fail_with_one_line(
    db: str, tmp_path: Path, text: str, message: str
) -> None:
    program = tmp_path / "bad.json"
    program.write_text(text)
    proc = run("query", str(program), "--scene", "cf", "--db", db)
    assert proc.returncode == 1
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("causalsplat: error: "), proc.stderr
    assert message in lines[0]


def test_missing_scene_and_file(db: str, tmp_path: Path) -> None:
    program = tmp_path / "p.json"
    program.write_text(removal(2).to_json())
    proc = run("query", str(program), "--scene", "nope", "--db", db)
    assert proc.returncode == 1 and "no scene 'nope'" in proc.stderr
    proc = run("query", str(tmp_path / "absent.json"), "--scene", "cf", "--db", db)
    assert proc.returncode != 0 and "absent.json" in proc.stderr
