"""The store benchmark's ORM baseline writes the rows ``save_scene`` writes (relation
evidence left out: the baseline hands the ORM the bulk path's pre-encoded JSON text, as it
always has, and the ORM encodes it once more)."""

from __future__ import annotations

from pathlib import Path

import sqlalchemy as sa

from causalsplat.bench.store import _orm_add_all, synthetic_graph
from graph_store import models as m
from graph_store import open_store

TABLES = (m.scenes, m.entities, m.entity_attributes, m.relations)
SKIP = {"created_at", "evidence"}


def _rows(url: str) -> dict[str, list[tuple[object, ...]]]:
    engine = sa.create_engine(url)
    with engine.connect() as conn:
        out = {
            t.name: sorted(
                tuple(v for k, v in r._mapping.items() if k not in SKIP)
                for r in conn.execute(sa.select(t))
            )
            for t in TABLES
        }
    engine.dispose()
    return out


def test_orm_baseline_writes_the_same_rows_as_save_scene(tmp_path: Path) -> None:
    graph = synthetic_graph(20)
    core, orm = f"sqlite:///{tmp_path / 'core.db'}", f"sqlite:///{tmp_path / 'orm.db'}"
    with open_store(core) as store:
        store.save_scene(graph)
    _orm_add_all(orm, graph)
    _orm_add_all(f"sqlite:///{tmp_path / 'again.db'}", graph)  # the mapping is made once
    expected = _rows(core)
    assert _rows(orm) == expected and len(expected["relations"]) == 200
