"""The repository against real databases: SQLite and PostgreSQL (``db_url`` runs both)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import sqlalchemy as sa
from hypothesis import HealthCheck, given, settings

from graph_store import (
    Entity,
    EntityNotFound,
    GraphStoreError,
    InvalidSceneError,
    Relation,
    SceneExistsError,
    SceneGraph,
    SceneMeta,
    SceneNotFound,
    SchemaVersionError,
    StoreConnectionError,
    StoreNotFoundError,
    open_store,
)
from graph_store import models as m
from tests.strategies import random_scene, scene_graphs

HYPOTHESIS = settings(
    max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)


def small_scene(scene_id: str = "kitchen") -> SceneGraph:
    table = Entity(0, "table", (0, 0, 0.4), (-1, -0.5, 0), (1, 0.5, 0.8), external_id="t")
    cup = Entity(1, "cup", (0, 0, 0.85), (-0.05, -0.05, 0.8), (0.05, 0.05, 0.9), external_id="c")
    rels = (Relation(1, 0, "supported_by", {"gap": 0.0}), Relation(0, 1, "supports", {"gap": 0.0}))
    return SceneGraph(SceneMeta(scene_id), (table, cup), rels)


@given(graph=scene_graphs())
@HYPOTHESIS
def test_load_of_save_is_identity(db_url: str, graph: SceneGraph) -> None:
    with open_store(db_url) as store:
        store.save_scene(graph, if_exists="replace")
        assert store.load_scene(graph.scene_id) == graph
        store.delete_scene(graph.scene_id)
        assert not store.has_scene(graph.scene_id)


def test_round_trip_of_thousands_of_entities(db_url: str) -> None:
    graph = random_scene("big", 5_000, 20_000, seed=3)
    labels = np.random.default_rng(0).integers(-1, 5_000, size=200_000)
    with open_store(db_url) as store:
        store.save_scene(graph, gaussian_labels=labels)
        assert store.load_scene("big") == graph
        np.testing.assert_array_equal(store.load_gaussian_labels("big"), labels)
        [summary] = store.list_scenes()
        assert (summary.entity_count, summary.relation_count) == (5_000, 20_000)


def test_empty_scene_round_trips(db_url: str) -> None:
    graph = SceneGraph(SceneMeta("empty", units="mm", up_axis="y"))
    with open_store(db_url) as store:
        store.save_scene(graph)
        assert store.load_scene("empty") == graph
        assert store.load_gaussian_labels("empty") is None


def test_if_exists_fail_keeps_the_old_scene_and_replace_swaps_it(db_url: str) -> None:
    with open_store(db_url) as store:
        store.save_scene(small_scene())
        other = SceneGraph(SceneMeta("kitchen", name="v2"), (small_scene().entities[0],))
        with pytest.raises(SceneExistsError, match="'kitchen' is already stored"):
            store.save_scene(other)
        assert store.load_scene("kitchen") == small_scene()
        store.save_scene(other, if_exists="replace")
        assert store.load_scene("kitchen") == other
        with pytest.raises(ValueError, match="if_exists"):
            store.save_scene(other, if_exists="merge")  # type: ignore[arg-type]


def test_delete_cascades_to_every_owned_row(db_url: str) -> None:
    with open_store(db_url) as store:
        store.save_scene(small_scene("a"), gaussian_labels=[0, 1, -1])
        store.save_scene(small_scene("b"))
        store.delete_scene("a")
        with store.engine.connect() as conn:
            for table in (m.entities, m.relations, m.entity_attributes, m.gaussian_labels):
                count = conn.execute(
                    sa.select(sa.func.count()).select_from(table).where(table.c.scene_id == "a")
                ).scalar_one()
                assert count == 0, table.name
        assert store.load_scene("b") == small_scene("b")
        with pytest.raises(SceneNotFound, match="no scene 'a'"):
            store.delete_scene("a")
        with pytest.raises(SceneNotFound):
            store.load_scene("a")


def test_entity_lookups(db_url: str) -> None:
    with open_store(db_url) as store:
        store.save_scene(small_scene())
        assert store.get_entity("kitchen", 1).category == "cup"
        assert store.find_entity("kitchen", 7) is None
        assert store.has_entity("kitchen", 0) and not store.has_entity("kitchen", 7)
        found = store.find_entity_by_external_id("kitchen", "t")
        assert found is not None and found.id == 0
        with pytest.raises(EntityNotFound, match="scene 'kitchen' has no entity 7"):
            store.get_entity("kitchen", 7)
        with pytest.raises(SceneNotFound):
            store.find_entity("nowhere", 0)


def test_gaussian_labels_are_checked_and_nothing_is_written_on_error(db_url: str) -> None:
    with open_store(db_url) as store:
        with pytest.raises(InvalidSceneError, match=r"refer to missing entities \[5\]"):
            store.save_scene(small_scene(), gaussian_labels=[0, 5])
        with pytest.raises(InvalidSceneError, match="1-D"):
            store.save_scene(small_scene(), gaussian_labels=[[0]])
        with pytest.raises(InvalidSceneError, match="integers"):
            store.save_scene(small_scene(), gaussian_labels=[0.5])
        assert store.list_scenes() == []
        store.save_scene(small_scene())
        store.save_gaussian_labels("kitchen", np.array([1, 1, 0, -1], dtype=np.int16))
        np.testing.assert_array_equal(store.load_gaussian_labels("kitchen"), [1, 1, 0, -1])


def test_corrupt_gaussian_labels_are_detected(db_url: str) -> None:
    with open_store(db_url) as store:
        store.save_scene(small_scene(), gaussian_labels=np.arange(2).repeat(100))
        with store.engine.begin() as conn:
            conn.execute(sa.update(m.gaussian_labels).values(sha256="0" * 64))
        with pytest.raises(GraphStoreError, match="checksum mismatch"):
            store.load_gaussian_labels("kitchen")


def test_schema_revision_is_checked(db_url: str) -> None:
    with open_store(db_url) as store, store.engine.begin() as conn:
        conn.execute(sa.text("UPDATE alembic_version SET version_num = '9999'"))
    with pytest.raises(SchemaVersionError, match=r"revision '9999'.*causalsplat db upgrade"):
        open_store(db_url)


def test_open_without_create_refuses_an_empty_database(db_url: str) -> None:
    if db_url.startswith("sqlite:///"):
        path = Path(db_url.removeprefix("sqlite:///"))
        with pytest.raises(StoreNotFoundError, match="does not exist"):
            open_store(db_url, create=False)
        assert not path.exists()  # a read-only open creates no file
        path.touch()
    with pytest.raises(SchemaVersionError, match="holds no store"):
        open_store(db_url, create=False)


@pytest.mark.parametrize(
    ("url", "message"),
    [
        ("sqlite:/no-slashes.db", "malformed database URL"),
        ("mysql://u@localhost/db", "unsupported database 'mysql'"),
        ("sqlite:////nonexistent-dir/sub/store.db", "cannot open the store"),
        ("postgresql+psycopg://nobody@127.0.0.1:1/none", "cannot open the store"),
    ],
)
def test_bad_or_unreachable_urls_are_typed_errors(url: str, message: str) -> None:
    with pytest.raises(StoreConnectionError, match=message):
        open_store(url)


def test_a_plain_path_is_a_sqlite_file_created_by_the_first_write(tmp_path: Path) -> None:
    path = tmp_path / "typo.db"
    with open_store(str(path)) as store:  # no sqlite:/// prefix: a file path
        assert store.pending and store.list_scenes() == []
        with pytest.raises(SceneNotFound, match="no such file: check the path"):
            store.load_scene("kitchen")
        assert not path.exists()  # reading a mistyped path creates nothing
        store.save_scene(small_scene("kitchen"))
        assert path.exists() and not store.pending
    with open_store(f"sqlite:///{path}", create=False) as store:
        assert [s.scene_id for s in store.list_scenes()] == ["kitchen"]


def test_a_store_in_a_missing_directory_fails_at_open(tmp_path: Path) -> None:
    with pytest.raises(StoreConnectionError, match="no such directory"):
        open_store(str(tmp_path / "no" / "such" / "store.db"))


def test_sqlite_runs_in_wal_mode_with_foreign_keys(sqlite_url: str) -> None:
    with open_store(sqlite_url) as store, store.engine.connect() as conn:
        assert conn.exec_driver_sql("PRAGMA journal_mode").scalar() == "wal"
        assert conn.exec_driver_sql("PRAGMA foreign_keys").scalar() == 1
        assert conn.exec_driver_sql("PRAGMA busy_timeout").scalar() >= 1000


def test_database_constraints_back_the_python_checks(db_url: str) -> None:
    """A row written around the types (raw SQL) still cannot break references."""
    with open_store(db_url) as store:
        store.save_scene(small_scene())
        with pytest.raises(sa.exc.IntegrityError), store.engine.begin() as conn:
            conn.execute(
                sa.insert(m.relations).values(
                    scene_id="kitchen", src=0, dst=99, type="near", evidence={}
                )
            )
        with pytest.raises(sa.exc.IntegrityError), store.engine.begin() as conn:
            conn.execute(
                sa.insert(m.relations).values(
                    scene_id="kitchen", src=0, dst=1, type="on_top_of", evidence={}
                )
            )
        assert store.load_scene("kitchen") == small_scene()
