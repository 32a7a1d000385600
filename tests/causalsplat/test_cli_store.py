"""The store commands through the real ``causalsplat`` command line."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import rdflib

from tests.causalsplat.test_objects import KITCHEN, NAN_CENTER
from tests.conftest import COMMAND_TIMEOUT_S, REPO_ROOT

COMMANDS = [["ingest-objects"], ["scenes"], ["export"], ["sparql"], ["db"], ["db", "upgrade"],
            ["db", "current"], ["build-many"]]  # fmt: skip


def run(*args: str, db: str | None = None, check: bool = True) -> subprocess.CompletedProcess[str]:
    argv = [sys.executable, "-m", "causalsplat", *args]
    if db is not None:
        argv += ["--db", db]
    proc = subprocess.run(
        argv,
        capture_output=True,
        text=True,
        cwd=REPO_ROOT,
        env={**os.environ},
        timeout=COMMAND_TIMEOUT_S,
    )
    if check and proc.returncode != 0:
        raise AssertionError(f"{argv} failed ({proc.returncode}): {proc.stderr}")
    return proc


def assert_one_line_error(proc: subprocess.CompletedProcess[str], pattern: str) -> None:
    assert proc.returncode != 0
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith("causalsplat: error: ")
    assert pattern in lines[0], lines[0]


@pytest.mark.parametrize("command", COMMANDS, ids=" ".join)
def test_every_command_has_help(command: list[str]) -> None:
    out = run(*command, "--help").stdout
    assert "Usage:" in out and len(out.splitlines()) > 3


def test_ingest_list_export_and_query(tmp_path: Path) -> None:
    db = f"sqlite:///{tmp_path / 'store.db'}"
    objects = tmp_path / "objects.json"
    objects.write_text(json.dumps(KITCHEN))
    ingested = json.loads(run("ingest-objects", str(objects), "--json", db=db).stdout)
    # Sink and towel are near each other with overlapping heights (next_to), both ways.
    assert ingested == {
        "scene_id": "kitchen",
        "entities": 2,
        "relations": 4,
        "relations_by_type": {"near": 2, "next_to": 2},
    }
    [row] = json.loads(run("scenes", "--json", db=db).stdout)
    assert (row["scene_id"], row["entities"]) == ("kitchen", 2)

    out = tmp_path / "kitchen.ttl"
    run("export", "--scene", "kitchen", "--format", "turtle", "-o", str(out), db=db)
    graph = rdflib.Graph().parse(out, format="turtle")
    assert len(graph) > 10

    query = "SELECT ?c WHERE { ?e csg:category ?c } ORDER BY ?c"
    result = json.loads(run("sparql", query, "--scene", "kitchen", "--json", db=db).stdout)
    assert result["head"]["vars"] == ["c"]
    assert [b["c"] for b in result["results"]["bindings"]] == [
        {"type": "literal", "value": "sink"},
        {"type": "literal", "value": "towel"},
    ]
    bound = run(
        "sparql", "SELECT ?e WHERE { ?e csg:category ?c }", "--bind", "c=towel", "--json", db=db
    ).stdout
    [binding] = json.loads(bound)["results"]["bindings"]
    assert binding["e"]["type"] == "uri"


def test_errors_are_one_line_with_non_zero_exit_and_write_nothing(tmp_path: Path) -> None:
    db = f"sqlite:///{tmp_path / 'store.db'}"
    objects = tmp_path / "objects.json"
    objects.write_text(json.dumps(KITCHEN))
    run("ingest-objects", str(objects), db=db)

    assert_one_line_error(run("ingest-objects", str(objects), db=db, check=False), "already stored")
    bad = tmp_path / "bad.json"
    bad.write_text(NAN_CENTER)
    assert_one_line_error(run("ingest-objects", str(bad), db=db, check=False), "NaN")
    assert_one_line_error(
        run("ingest-objects", str(tmp_path / "missing.json"), db=db, check=False), "missing.json"
    )
    for update in (
        "INSERT DATA { <urn:a> <urn:b> <urn:c> }",
        "LOAD <http://127.0.0.1:9/x.ttl>",
        "SELECT * WHERE { SERVICE <http://127.0.0.1:9/sparql> { ?s ?p ?o } }",
    ):
        assert_one_line_error(run("sparql", update, db=db, check=False), "")
    assert_one_line_error(run("export", "--scene", "nope", db=db, check=False), "no scene 'nope'")
    assert_one_line_error(
        run("scenes", db="postgresql+psycopg://nobody@127.0.0.1:1/none", check=False),
        "cannot open the store",
    )
    scenes = json.loads(run("scenes", "--json", db=db).stdout)
    assert [s["scene_id"] for s in scenes] == ["kitchen"]


def test_db_upgrade_and_current(tmp_path: Path) -> None:
    db = f"sqlite:///{tmp_path / 'fresh.db'}"
    assert json.loads(run("db", "upgrade", "--json", db=db).stdout) == {"from": None, "to": "0001"}
    assert run("db", "current", db=db).stdout.strip() == "0001"
    assert json.loads(run("db", "upgrade", "--json", db=db).stdout) == {
        "from": "0001",
        "to": "0001",
    }


def test_db_before_the_command_name(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """``causalsplat --db URL export ...`` as the help says every command takes --db; the
    command's own --db wins over it, and it wins over $CAUSALSPLAT_DB."""
    here = f"sqlite:///{tmp_path / 'here.db'}"
    doc = tmp_path / "objects.json"
    doc.write_text(json.dumps({"scene_id": "k", "objects": [
        {"id": 1, "label": "sink", "center": [0, 0, 0.9], "size": [0.6, 0.4, 0.2]}]}))  # fmt: skip
    run("--db", here, "ingest-objects", str(doc))
    assert "k " in run("--db", here, "scenes").stdout
    assert "sink" in run("--db", here, "export", "--format", "ntriples").stdout
    missing = f"sqlite:///{tmp_path / 'missing.db'}"
    assert "k " in run("--db", missing, "scenes", "--db", here).stdout
    refused = run("--db", missing, "scenes", check=False)
    assert_one_line_error(refused, "no store at")
    assert not (tmp_path / "missing.db").exists()
    monkeypatch.setenv("CAUSALSPLAT_DB", missing)
    assert "k " in run("--db", here, "scenes").stdout
    assert_one_line_error(run("scenes", check=False), "no store at")


def test_json_before_the_command_name(tmp_path: Path) -> None:
    """``causalsplat --json scenes`` as the help says every command takes --json before or
    after its name: the same document as ``scenes --json``, in a command group too."""
    here = f"sqlite:///{tmp_path / 'here.db'}"
    doc = tmp_path / "objects.json"
    doc.write_text(json.dumps({"scene_id": "k", "objects": [
        {"id": 1, "label": "sink", "center": [0, 0, 0.9], "size": [0.6, 0.4, 0.2]}]}))  # fmt: skip
    run("--db", here, "ingest-objects", str(doc))
    before = json.loads(run("--json", "--db", here, "scenes").stdout)
    assert before == json.loads(run("--db", here, "scenes", "--json").stdout)
    assert [s["scene_id"] for s in before] == ["k"]
    assert "k " in run("--db", here, "scenes").stdout  # no --json anywhere: text
    current = json.loads(run("--json", "--db", here, "db", "current").stdout)
    assert current == json.loads(run("--db", here, "db", "current", "--json").stdout)


def test_a_plain_path_for_db_is_a_sqlite_file(tmp_path: Path) -> None:
    doc = tmp_path / "objects.json"
    doc.write_text(json.dumps(KITCHEN))
    run("ingest-objects", str(doc), db=str(tmp_path / "plain.db"))  # no sqlite:/// prefix
    assert "kitchen " in run("scenes", db=f"sqlite:///{tmp_path / 'plain.db'}").stdout
    relative = run("ingest-objects", str(doc), "--db", "sub/rel.db", check=False)
    assert relative.returncode != 0  # REPO_ROOT/sub does not exist: refused, nothing made
    assert "no such directory" in relative.stderr and not (REPO_ROOT / "sub").exists()
    refused = run("scenes", db=str(tmp_path / "typo.db"), check=False)
    assert_one_line_error(refused, "no store at")
    assert not (tmp_path / "typo.db").exists()
