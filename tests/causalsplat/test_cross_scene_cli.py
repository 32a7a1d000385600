"""Questions across scenes through the API (``Store.query_all`` / ``ask_all``) and the real
command line (``query``, ``ask``, ``scenes``, ``sparql`` with ``--scenes`` /
``--all-scenes``)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from causalsplat.api import open_store
from tests.queries.test_query_cli import run
from tests.queries.test_query_multi_scene import COUNTERFACTUAL, _support_scene

SCENES = {"room_a": True, "room_b": False, "room_c": True, "hall": True}


@pytest.fixture
def db(tmp_path: Path) -> str:
    url = f"sqlite:///{tmp_path / 'store.db'}"
    with open_store(url) as store:
        for sid, with_cup in SCENES.items():
            store.save_scene(_support_scene(sid, with_cup))
    return url


def test_api_matches_each_scene(db: str) -> None:
    with open_store(db, create=False) as store:
        assert store.scene_ids("room_*") == ("room_a", "room_b", "room_c")
        for executor in ("sql", "sparql", "networkx"):
            results = store.query_all(COUNTERFACTUAL, scenes="room_*", executor=executor)
            assert list(results) == ["room_a", "room_b", "room_c"]
            for sid, result in results.items():
                assert result == store.scene(sid).run(COUNTERFACTUAL, executor="networkx")
        answers = store.ask_all("the cup on the table", reasoner="offline", embeddings=False)
        assert list(answers) == sorted(SCENES)
        for sid, answer in answers.items():
            alone = store.scene(sid).ask("the cup on the table", embeddings=False)
            assert answer == alone
        assert [sid for sid, a in answers.items() if a.entity_ids] == ["hall", "room_a", "room_c"]


def test_query_across_scenes_human_and_json(db: str, tmp_path: Path) -> None:
    program = tmp_path / "p.json"
    program.write_text(json.dumps(COUNTERFACTUAL))
    proc = run("query", str(program), "--all-scenes", "--db", db)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert lines[0] == "hall: 2 entities"
    assert lines[1].split() == ["3", "cup"]  # no input id: no "ext=None"
    assert "room_b" not in proc.stdout
    assert lines[-1] == "3 of 4 scenes answered"
    proc = run("query", str(program), "--scenes", "room_*", "--db", db, "--json")
    assert proc.returncode == 0, proc.stderr
    doc = json.loads(proc.stdout)
    assert (doc["scenes"], doc["answered"], doc["executor"]) == (3, 2, "sql")
    assert [r["scene_id"] for r in doc["results"]] == ["room_a", "room_b", "room_c"]
    assert doc["results"][1]["answer"] == [] and doc["results"][1]["entities"] == []
    assert [e["category"] for e in doc["results"][0]["entities"]] == ["cup", "spoon"]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--scenes", "nothing*"], "no stored scene matches 'nothing*' (4 stored)"),
        (["--scene", "hall", "--all-scenes"], "--scene and --all-scenes are mutually exclusive"),
        (["--scenes", "r*", "--all-scenes"], "--scenes and --all-scenes are mutually exclusive"),
        ([], "give --scene ID, --scenes GLOB or --all-scenes"),
    ],
)
def test_bad_selections_are_one_line(
    db: str, tmp_path: Path, args: list[str], message: str
) -> None:
    program = tmp_path / "p.json"
    program.write_text(json.dumps(COUNTERFACTUAL))
    proc = run("query", str(program), *args, "--db", db)
    assert proc.returncode != 0 and proc.stdout == ""
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"causalsplat: error: {message}")


def test_ask_scenes_and_sparql_across_scenes(db: str, tmp_path: Path) -> None:
    proc = run("ask", "the cup on the table", "--scenes", "room_*", "--no-embeddings",
               "--db", db, "--json")  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    doc = json.loads(proc.stdout)
    assert (doc["scenes"], doc["answered"]) == (3, 2)
    assert [r["answer"] for r in doc["results"]] == [[3], [], [3]]
    proc = run("scenes", "--scenes", "room_[ab]", "--db", db, "--json")
    assert proc.returncode == 0, proc.stderr
    assert [s["scene_id"] for s in json.loads(proc.stdout)] == ["room_a", "room_b"]
    count = (
        "SELECT ?s (COUNT(?e) AS ?n) WHERE { ?s bot:containsElement ?e } GROUP BY ?s ORDER BY ?s"
    )
    proc = run("sparql", count, "--scenes", "room_*", "--db", db, "--format", "csv")
    assert proc.returncode == 0, proc.stderr
    assert [line.rsplit(",", 1)[1] for line in proc.stdout.splitlines()[1:]] == ["4", "2", "4"]
    proc = run("sparql", count, "--scene", "hall", "--all-scenes", "--db", db)
    assert proc.returncode != 0 and "mutually exclusive" in proc.stderr
    missing = tmp_path / "missing.db"
    proc = run("query", "-", "--all-scenes", "--db", f"sqlite:///{missing}", stdin="x")
    assert proc.returncode != 0 and not missing.exists()
