"""``docs/store.md`` against the code: every table and column of a fresh store, every
relation type, attribute source and evidence key the rules emit is documented (and nothing
that does not exist), and the page's examples run on a store made here.

The examples' printed results come from a built synthetic room; here the ``room`` scene is
made from boxes, so the ``sqlite3`` examples are held to their column headers (and the
foreign-key example, whose numbers do not depend on the room, to its whole output).
"""

from __future__ import annotations

import re
import shutil
import sqlite3
import subprocess
from pathlib import Path

import numpy as np
import pytest

from causalsplat.graph.edges import build_relations
from causalsplat.objects import objects_to_scene_graph, parse_objects
from graph_store import (
    STORED_RELATION_TYPES,
    Attribute,
    AttributeSource,
    Entity,
    SceneGraph,
    SceneMeta,
    decode_labels,
    open_store,
)
from graph_store.models import metadata
from tests.causalsplat.test_objects import KITCHEN
from tests.conftest import COMMAND_TIMEOUT_S, REPO_ROOT

DOC = REPO_ROOT / "docs" / "store.md"
#: ``(category, lower corner, upper corner)``: a floor, a table on it, a cup on the table,
#: a shelf with a box inside, a chair beside the table: every relation rule fires.
BOXES = [
    ("floor", (0.0, 0.0, -0.05), (4.0, 4.0, 0.0)),
    ("table", (1.0, 1.0, 0.0), (2.0, 2.0, 0.8)),
    ("cup", (1.4, 1.4, 0.8), (1.5, 1.5, 0.9)),
    ("shelf", (3.0, 0.2, 0.0), (3.6, 0.6, 1.8)),
    ("box", (3.1, 0.3, 0.5), (3.3, 0.5, 0.7)),
    ("fridge", (2.1, 1.2, 0.0), (2.5, 1.6, 0.9)),
]


def _text() -> str:
    return DOC.read_text(encoding="utf-8")


def _sections(text: str) -> dict[str, list[str]]:
    """``### `name` `` heading -> the backquoted first cells of its table's rows."""
    out: dict[str, list[str]] = {}
    current = None
    for line in text.splitlines():
        heading = re.match(r"^### `(\w+)`$", line)
        if heading:
            current = heading.group(1)
            out[current] = []
        elif line.startswith("## ") or line.startswith("### "):
            current = None
        elif current is not None and (cell := re.match(r"^\| `(\w+)` \|", line)):
            out[current].append(cell.group(1))
    return out


def _room() -> tuple[SceneGraph, np.ndarray]:
    entities = []
    for k, (category, lo, hi) in enumerate(BOXES):
        centre = tuple((a + b) / 2 for a, b in zip(lo, hi, strict=True))
        share = "0.999" if category == "fridge" else "1.000"
        attrs = (Attribute("label_vote", f"{category}:{share}", AttributeSource.MASK_VOTE),
                 Attribute("color", "white", AttributeSource.GEOMETRY))  # fmt: skip
        entities.append(Entity(k, category, centre, lo, hi, point_count=10, confidence=1.0,
                               attributes=attrs))  # fmt: skip
    relations = build_relations(entities)
    meta = SceneMeta("room", source="build", config_hash="c0ffee", provenance={
        "point_cloud.ply": "0" * 64, "sparse/0/cameras.txt": "1" * 64,
        "masks/view_000.npz": "2" * 64, "source_dir": "/nowhere/scene"})  # fmt: skip
    labels = np.repeat(np.arange(-1, len(BOXES)), 10).astype(np.int32)
    return SceneGraph(meta, tuple(entities), relations), labels


@pytest.fixture
def store(tmp_path: Path) -> Path:
    """``store.db`` in ``tmp_path`` with the scenes of the page's examples."""
    path = tmp_path / "store.db"
    graph, labels = _room()
    with open_store(f"sqlite:///{path}") as s:
        s.save_scene(graph, gaussian_labels=labels)
        s.save_scene(objects_to_scene_graph(parse_objects(KITCHEN)))
    return path


def test_every_table_and_column_is_documented(store: Path) -> None:
    with sqlite3.connect(store) as con:
        tables = {r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type='table'")}
        live = {t: [r[1] for r in con.execute(f"PRAGMA table_info({t})")] for t in tables}
    assert "sqlite_stat1" in tables and "sqlite_stat1" in _text()
    del live["sqlite_stat1"]
    documented = _sections(_text())
    assert documented == live
    assert set(metadata.tables) | {"alembic_version"} == set(documented)
    for name, table in metadata.tables.items():
        assert [c.name for c in table.columns] == documented[name]


def test_every_evidence_key_and_relation_type_is_documented() -> None:
    graph, _ = _room()
    emitted: dict[str, set[str]] = {}
    for r in graph.relations:
        emitted.setdefault(r.type.value, set()).update(dict(r.evidence))
    assert set(emitted) == {t.value for t in STORED_RELATION_TYPES}, "a rule did not fire"
    text = _text()
    rows = re.findall(r"^\| (`\w+`(?:, `\w+`)*) \| (`\w+`(?:, `\w+`)*) \|$", text, re.M)
    documented: dict[str, set[str]] = {}
    for types, keys in rows:
        for t in re.findall(r"`(\w+)`", types):
            documented[t] = set(re.findall(r"`(\w+)`", keys))
    assert {t: documented.get(t) for t in emitted} == emitted
    glossary = set(re.findall(r"^\| `(\w+)` \| (?:scene units|ratio) \|", text, re.M))
    assert glossary == set().union(*emitted.values())


def test_every_attribute_source_is_documented() -> None:
    [row] = [line for line in _text().splitlines() if line.startswith("| `source` | text(32)")]
    assert set(re.findall(r"`([\w-]+)`", row)) - {"source"} == {s.value for s in AttributeSource}


def _blocks(language: str) -> list[str]:
    return re.findall(rf"```{language}\n(.*?)```", _text(), re.S)


def test_the_python_examples_run(store: Path, monkeypatch: pytest.MonkeyPatch,
                                 capsys: pytest.CaptureFixture[str]) -> None:  # fmt: skip
    monkeypatch.chdir(store.parent)
    blocks = _blocks("python")
    assert len(blocks) == 3
    decoded: dict[str, object] = {}
    exec(blocks[0], decoded)  # graph_store.decode_labels
    assert "int32 (70,) 10 Gaussians with no entity" in capsys.readouterr().out
    raw: dict[str, object] = {}
    exec(blocks[1], raw)  # numpy and zlib only
    np.testing.assert_array_equal(raw["labels"], decoded["labels"])  # type: ignore[arg-type]
    np.testing.assert_array_equal(raw["labels"], _room()[1])  # type: ignore[arg-type]


def test_the_pandas_example_runs(store: Path, monkeypatch: pytest.MonkeyPatch,
                                 capsys: pytest.CaptureFixture[str]) -> None:  # fmt: skip
    pytest.importorskip("pandas")
    monkeypatch.chdir(store.parent)
    exec(_blocks("python")[2], {})
    header = capsys.readouterr().out.split()[:6]
    assert header == ["src", "dst", "distance", "gap", "overlap", "touch_tolerance"]


def _commands(block: str) -> list[tuple[str, list[str]]]:
    """``(command, expected output lines)`` of a console block (``$ `` and 4-space
    continuation lines)."""
    out: list[tuple[str, list[str]]] = []
    for line in block.splitlines():
        if line.startswith("$ "):
            out.append((line[2:], []))
        elif line.startswith("    ") and out and not out[-1][1]:
            out[-1] = (out[-1][0] + "\n" + line, [])
        elif out:
            out[-1][1].append(line.rstrip())
    return out


@pytest.mark.skipif(shutil.which("sqlite3") is None, reason="no sqlite3 shell")
def test_the_sqlite3_examples_run(store: Path, tmp_path: Path) -> None:
    pristine = tmp_path / "pristine.db"
    shutil.copyfile(store, pristine)
    ran = 0
    for block in _blocks("console"):
        shutil.copyfile(pristine, store)  # each block starts from the same store
        for command, expected in _commands(block):
            if not command.startswith("sqlite3 "):
                continue
            proc = subprocess.run(["bash", "-c", command], capture_output=True, text=True,
                                  cwd=tmp_path, timeout=COMMAND_TIMEOUT_S)  # fmt: skip
            assert proc.returncode == 0 and not proc.stderr, (command, proc.stderr)
            got = [line.rstrip() for line in proc.stdout.rstrip("\n").splitlines()]
            if "-header" in command:
                assert got[0].split() == expected[0].split(), command  # widths follow the data
            else:
                assert got == expected, command
            ran += 1
    assert ran == 7


@pytest.mark.postgres
def test_postgres_has_the_documented_columns_and_types(postgres_url: str) -> None:
    """The same tables and columns on PostgreSQL, the types the page names, the ``->>``
    of the psql example, and the labels blob as psycopg returns it."""
    import sqlalchemy as sa

    graph, labels = _room()
    with open_store(postgres_url) as s:
        s.save_scene(graph, gaussian_labels=labels)
        with s.engine.connect() as conn:
            rows = conn.execute(sa.text(
                "SELECT table_name, column_name, data_type FROM information_schema.columns"
                " WHERE table_schema = 'public' ORDER BY table_name, ordinal_position"
            )).all()  # fmt: skip
            gap = conn.execute(sa.text(
                "SELECT evidence->>'gap' FROM relations WHERE scene_id = 'room'"
                " AND type = 'supported_by' AND src = 2 AND dst = 1"
            )).scalar_one()  # fmt: skip
            data = conn.execute(sa.text("SELECT data FROM gaussian_labels")).scalar_one()
    live: dict[str, list[str]] = {}
    types = {}
    for table, column, data_type in rows:
        live.setdefault(table, []).append(column)
        types[(table, column)] = data_type
    assert live == _sections(_text())
    assert types[("relations", "evidence")] == "json"
    assert types[("gaussian_labels", "data")] == "bytea"
    assert types[("scenes", "created_at")] == "timestamp with time zone"
    assert types[("entities", "cx")] == "double precision"
    [cup_on_table] = [
        r for r in graph.relations if (r.src, r.type.value, r.dst) == (2, "supported_by", 1)
    ]
    assert float(gap) == cup_on_table.evidence_dict["gap"]
    np.testing.assert_array_equal(decode_labels(data, count=labels.size), labels)
