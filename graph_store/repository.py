"""The repository: save, load, list and delete scene graphs in a database.

>>> store = open_store("sqlite:///scenes.db")                      # doctest: +SKIP
>>> store.save_scene(graph)         # one transaction; fails if the id exists  # doctest: +SKIP
>>> store.save_scene(graph, if_exists="replace")  # or replaces it             # doctest: +SKIP
>>> store.load_scene("scene0000_00") == graph                     # doctest: +SKIP
True

Writes go through SQLAlchemy Core ``insert()`` executemany (not the ORM unit of work),
inside a single transaction: a crash at any point leaves the earlier contents of the
database intact and no partial scene visible.
"""

from __future__ import annotations

import errno
import json
import os
import sqlite3
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any, Literal

import numpy as np
import numpy.typing as npt
import sqlalchemy as sa
from sqlalchemy.engine import Connection, Engine

from graph_store import models as m
from graph_store._engine import (
    WRITE,
    as_url,
    create_store_engine,
    describe_url,
    missing_sqlite_file,
    on_read_only_filesystem,
)
from graph_store._schema import ensure_schema
from graph_store.errors import (
    EntityNotFound,
    GraphStoreError,
    SceneExistsError,
    SceneNotFound,
    StoreConnectionError,
    StoreNotFoundError,
)
from graph_store.labels import EncodedLabels, check_labels, decode_row, encode_labels
from graph_store.types import (
    Attribute,
    AttributeSource,
    Entity,
    MaskRecord,
    SceneGraph,
    SceneMeta,
    View,
    check_scene_id,
    trusted_entity,
    trusted_relation,
    trusted_scene_graph,
)

IfExists = Literal["fail", "replace"]

#: JSON text for the bulk path (evidence values are validated finite floats).
_dumps = json.JSONEncoder(separators=(",", ":"), allow_nan=False, ensure_ascii=False).encode


@dataclass(frozen=True, slots=True)
class SceneSummary:
    """One row of :meth:`GraphStore.list_scenes`."""

    scene_id: str
    name: str | None
    source: str
    units: str
    up_axis: str
    entity_count: int
    relation_count: int
    created_at: datetime
    config_hash: str | None


def open_store(
    url: str | os.PathLike[str], *, create: bool = True, echo: bool = False
) -> GraphStore:
    """Open (and, for an empty database with ``create=True``, initialise) a store: a
    database URL, or a SQLite file's path.

    With ``create=False`` nothing is written: a SQLite file that does not exist raises
    :class:`StoreNotFoundError` instead of being created, and one on a read-only filesystem
    is opened as immutable (it can be read, not written). Raises
    :class:`StoreConnectionError` when the URL is malformed, the database cannot be reached
    or the file is not a database, and :class:`SchemaVersionError` when its schema needs a
    migration.
    """
    given = as_url(url)
    url = given if isinstance(given, str) else given.render_as_string(hide_password=False)
    if not create:
        missing = missing_sqlite_file(url)
        if missing is not None:
            raise StoreNotFoundError(
                f"no store at {describe_url(url)}: {missing} does not exist"
                " (`causalsplat build` or `ingest-objects` creates one)"
            )
    elif (missing := missing_sqlite_file(url)) is not None:
        folder = os.path.dirname(os.path.abspath(missing))
        if not os.path.isdir(folder):
            raise StoreConnectionError(
                f"cannot open the store at {describe_url(url)}: no such directory {folder}"
            )
        return GraphStore(None, pending=(str(url), echo))
    read_only = not create and on_read_only_filesystem(url)
    return GraphStore(_open_engine(url, echo=echo, read_only=read_only, create=create))


def _open_engine(url: str, *, echo: bool, read_only: bool, create: bool) -> Engine:
    engine = create_store_engine(url, echo=echo, read_only=read_only)
    try:
        ensure_schema(engine, create=create)
    except sa.exc.DatabaseError as exc:  # OperationalError, "file is not a database", ...
        engine.dispose()
        reason = str(exc.orig).strip().splitlines()[0] if exc.orig else str(exc)
        raise StoreConnectionError(
            f"cannot open the store at {describe_url(url)}: {reason}"
        ) from exc
    except BaseException:
        engine.dispose()
        raise
    return engine


class GraphStore:
    """Scene graphs persisted in one SQLite or PostgreSQL database.

    A store opened with ``create=True`` on a SQLite file that does not exist is *pending*:
    it reads as empty and its file is created by the first write (or by the first use of
    :attr:`engine`), so that opening a mistyped path to read from it creates nothing.
    """

    def __init__(self, engine: Engine | None, *, pending: tuple[str, bool] | None = None) -> None:
        if (engine is None) == (pending is None):
            raise ValueError("GraphStore needs an engine or a pending SQLite URL, not both")
        self._engine = engine
        self._pending = pending
        self._empty: Engine | None = None

    @property
    def engine(self) -> Engine:
        """The SQLAlchemy engine (a pending store's file is created here)."""
        return self.initialise()._ready()

    def _ready(self) -> Engine:
        assert self._engine is not None
        return self._engine

    def initialise(self) -> GraphStore:
        """Create a pending store's file and schema now (its first write would), so that
        other processes can open it with ``create=False``; no-op otherwise."""
        if self._engine is None:
            self._materialise()
        return self

    @property
    def pending(self) -> bool:
        """Whether this store's SQLite file does not exist yet (class docstring)."""
        return self._engine is None

    def _materialise(self) -> None:
        assert self._pending is not None
        url, echo = self._pending
        self._engine = _open_engine(url, echo=echo, read_only=False, create=True)
        self._pending = None
        if self._empty is not None:
            self._empty.dispose()
            self._empty = None

    @property
    def url(self) -> str:
        return describe_url(self._pending[0] if self._pending else self.engine.url)

    @property
    def dialect(self) -> str:
        """``"sqlite"`` or ``"postgresql"``."""
        return "sqlite" if self._pending else self.engine.dialect.name

    def close(self) -> None:
        if self._engine is not None:
            self._engine.dispose()
        if self._empty is not None:
            self._empty.dispose()

    def __enter__(self) -> GraphStore:
        return self

    def __exit__(self, *_exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"GraphStore({self.url!r})"

    # -- transactions ------------------------------------------------------------------

    @contextmanager
    def _read(self) -> Iterator[Connection]:
        with self._wrap_errors(), self._reader().connect() as conn, conn.begin():
            yield conn

    def _reader(self) -> Engine:
        """The engine reads go to: while pending, an empty in-memory store, unless the
        file has been created meanwhile (by another process), which is then opened."""
        if self._pending is None:
            return self.engine
        if missing_sqlite_file(self._pending[0]) is None:
            self._materialise()
            return self.engine
        if self._empty is None:
            self._empty = _open_engine("sqlite://", echo=False, read_only=False, create=True)
        return self._empty

    @contextmanager
    def _write(self) -> Iterator[Connection]:
        with (
            self._wrap_errors(),
            self.engine.connect().execution_options(**WRITE) as conn,
            conn.begin(),
        ):
            yield conn
        self._checkpoint()

    def _checkpoint(self) -> None:
        """After a committed write to SQLite, copy the write-ahead log into the database
        file (a passive checkpoint: it waits for no reader), so that the ``.db`` file alone
        holds every committed scene, even while another process (``serve``) has the store
        open. What a reader still needs stays in the log until the next write."""
        if self.dialect != "sqlite":
            return
        with self._wrap_errors(), self.engine.connect() as conn:
            conn.exec_driver_sql("PRAGMA wal_checkpoint(PASSIVE)")

    def backup(self, path: str | os.PathLike[str]) -> Path:
        """Copy a SQLite store, consistently even while others read or write it, into the
        new file ``path`` (SQLite's online backup), and return its path. The copy is a
        store on its own (no write-ahead log beside it). Raises :class:`StoreConnectionError`
        for a PostgreSQL store (use ``pg_dump``) and :class:`FileExistsError` when ``path``
        exists."""
        if self.dialect != "sqlite":
            raise StoreConnectionError(
                f"backup copies SQLite stores; for {self.url} use PostgreSQL's pg_dump"
            )
        target = Path(path)
        if target.exists():
            raise FileExistsError(errno.EEXIST, "the backup target exists", str(target))
        if not target.parent.is_dir():
            raise FileNotFoundError(errno.ENOENT, "no such directory", str(target.parent))
        tmp = target.with_name(f".{target.name}.tmp{os.getpid()}")
        try:
            with self._wrap_errors():
                raw = self._reader().raw_connection()
                try:
                    copy = sqlite3.connect(tmp)
                    try:
                        raw.driver_connection.backup(copy)  # type: ignore[union-attr]
                        copy.execute("PRAGMA journal_mode=DELETE")
                    finally:
                        copy.close()
                finally:
                    raw.close()
            os.link(tmp, target)  # fails, without replacing, when the target appeared meanwhile
        finally:
            tmp.unlink(missing_ok=True)
        return target

    @contextmanager
    def _wrap_errors(self) -> Iterator[None]:
        try:
            yield
        except (sa.exc.OperationalError, sa.exc.DatabaseError) as exc:
            if isinstance(exc, sa.exc.IntegrityError):
                raise
            reason = str(exc.orig).strip().splitlines()[0] if exc.orig else str(exc)
            raise StoreConnectionError(f"database error on {self.url}: {reason}") from exc

    # -- scenes --------------------------------------------------------------------------

    def save_scene(
        self,
        graph: SceneGraph,
        *,
        if_exists: IfExists = "fail",
        gaussian_labels: npt.ArrayLike | None = None,
    ) -> None:
        """Write a whole scene graph (and optionally its per-Gaussian labels) atomically.

        Args:
            graph: the scene graph; it was validated when constructed.
            if_exists: ``"fail"`` raises :class:`SceneExistsError` when a scene with the
                same id is stored; ``"replace"`` deletes it and writes the new one in the
                same transaction (readers see either the old or the new scene).
            gaussian_labels: ``(N,)`` integer array, the entity id of each Gaussian
                (``-1``: none); every id must be an entity of ``graph``.
        """
        if if_exists not in ("fail", "replace"):
            raise ValueError(f"if_exists must be 'fail' or 'replace', got {if_exists!r}")
        if not isinstance(graph, SceneGraph):
            raise TypeError(f"save_scene expects a SceneGraph, got {type(graph).__name__}")
        check_scene_id(graph.scene_id)
        encoded: EncodedLabels | None = None
        if gaussian_labels is not None:
            ids = [e.id for e in graph.entities]
            encoded = encode_labels(check_labels(gaussian_labels, ids, graph.scene_id))
        rows = _scene_rows(graph)
        sid = graph.scene_id
        try:
            with self._write() as conn:
                exists = conn.execute(sa.select(m.scenes.c.id).where(m.scenes.c.id == sid)).first()
                if exists is not None:
                    if if_exists == "fail":
                        raise SceneExistsError(
                            f"scene {sid!r} is already stored; pass if_exists='replace'"
                            " (CLI: --if-exists replace) to overwrite it"
                        )
                    _delete_scene_rows(conn, sid)
                conn.execute(sa.insert(m.scenes), [rows.scene])
                for table, batch in rows.children():
                    _insert_many(conn, table, batch)
                if encoded is not None:
                    conn.execute(
                        sa.insert(m.gaussian_labels),
                        [_labels_row(sid, encoded)],
                    )
        except sa.exc.IntegrityError as exc:
            # Another writer stored the same id between our check and our insert.
            raise SceneExistsError(f"scene {sid!r} was stored concurrently: {exc.orig}") from exc
        self._refresh_statistics()

    def _refresh_statistics(self) -> None:
        """Refresh the planner statistics after a bulk write.

        Without them SQLite plans a join of ``relations`` with itself as a scan per row
        (quadratic: seconds instead of milliseconds at 100k relations). The SQLite
        analysis is bounded (``analysis_limit``) so it stays cheap on large stores.
        """
        with self._wrap_errors(), self.engine.connect() as conn:
            if self.dialect == "sqlite":
                conn.exec_driver_sql("PRAGMA analysis_limit=2000")
                conn.exec_driver_sql("ANALYZE")
            else:
                names = ", ".join(t.name for t in (m.entities, m.entity_attributes, m.relations))
                conn.exec_driver_sql(f"ANALYZE {names}")
            conn.commit()

    def load_scene(self, scene_id: str) -> SceneGraph:
        """Read a whole scene graph back; raises :class:`SceneNotFound`."""
        with self._read() as conn:
            row = self._scene_row(conn, scene_id)
            ents = conn.execute(
                sa.select(m.entities).where(m.entities.c.scene_id == scene_id)
            ).all()
            attrs = _attributes_by_entity(conn, scene_id)
            rels = conn.execute(
                sa.select(
                    m.relations.c.src,
                    m.relations.c.dst,
                    m.relations.c.type,
                    sa.cast(m.relations.c.evidence, sa.Text),  # decoded below, in bulk
                ).where(m.relations.c.scene_id == scene_id)
            ).all()
            view_rows = conn.execute(sa.select(m.views).where(m.views.c.scene_id == scene_id)).all()
            mask_rows = conn.execute(sa.select(m.masks).where(m.masks.c.scene_id == scene_id)).all()
        loads = json.JSONDecoder().decode
        return trusted_scene_graph(
            _meta_from_row(row),
            (_entity_from_row(r, attrs.get(r.id, ())) for r in ents),
            (trusted_relation(src, dst, typ, loads(ev)) for src, dst, typ, ev in rels),
            (View(r.id, r.name, r.width, r.height) for r in view_rows),
            (MaskRecord(r.view_id, r.idx, r.entity_id, r.label, r.score) for r in mask_rows),
        )

    def has_scene(self, scene_id: str) -> bool:
        with self._read() as conn:
            found = conn.execute(sa.select(m.scenes.c.id).where(m.scenes.c.id == scene_id)).first()
        return found is not None

    def list_scenes(self) -> list[SceneSummary]:
        """All stored scenes, ordered by id."""
        with self._read() as conn:
            rows = conn.execute(sa.select(m.scenes).order_by(m.scenes.c.id)).all()
        return [_summary(r) for r in rows]

    def scene_summary(self, scene_id: str) -> SceneSummary:
        """One stored scene's summary (one row read); raises :class:`SceneNotFound`."""
        with self._read() as conn:
            return _summary(self._scene_row(conn, scene_id))

    def delete_scene(self, scene_id: str) -> None:
        """Delete a scene and everything it owns; raises :class:`SceneNotFound`."""
        with self._write() as conn:
            if not _delete_scene_rows(conn, scene_id):
                raise SceneNotFound(f"no scene {scene_id!r} in the store at {self.url}")

    def scene_meta(self, scene_id: str) -> SceneMeta:
        with self._read() as conn:
            return _meta_from_row(self._scene_row(conn, scene_id))

    def _scene_row(self, conn: Connection, scene_id: str) -> sa.Row[Any]:
        row = conn.execute(sa.select(m.scenes).where(m.scenes.c.id == scene_id)).first()
        if row is None:
            raise SceneNotFound(f"no scene {scene_id!r} in the store at {self.where}")
        return row

    @property
    def where(self) -> str:
        """The store's URL for a message; for a pending store, that its file is missing."""
        if self._pending is None:
            return self.url
        return f"{self.url} (no such file: check the path)"

    # -- entities ------------------------------------------------------------------------

    def find_entity(self, scene_id: str, entity_id: int) -> Entity | None:
        """The entity, or ``None`` when the scene has no such entity.

        Raises :class:`SceneNotFound` when the scene itself is missing.
        """
        return self._find_entity(scene_id, m.entities.c.id == entity_id)

    def get_entity(self, scene_id: str, entity_id: int) -> Entity:
        """The entity; raises :class:`EntityNotFound` (or :class:`SceneNotFound`)."""
        entity = self.find_entity(scene_id, entity_id)
        if entity is None:
            raise EntityNotFound(f"scene {scene_id!r} has no entity {entity_id!r}")
        return entity

    def has_entity(self, scene_id: str, entity_id: int) -> bool:
        return self.find_entity(scene_id, entity_id) is not None

    def find_entity_by_external_id(self, scene_id: str, external_id: str) -> Entity | None:
        """The entity whose input id was ``external_id``, or ``None``."""
        return self._find_entity(scene_id, m.entities.c.external_id == str(external_id))

    def _find_entity(self, scene_id: str, where: sa.ColumnElement[bool]) -> Entity | None:
        with self._read() as conn:
            self._scene_row(conn, scene_id)
            row = conn.execute(
                sa.select(m.entities).where(m.entities.c.scene_id == scene_id, where)
            ).first()
            if row is None:
                return None
            attrs = _attributes_by_entity(conn, scene_id, row.id)
        return _entity_from_row(row, attrs.get(row.id, ()))

    # -- per-Gaussian labels -------------------------------------------------------------

    def load_gaussian_labels(self, scene_id: str) -> npt.NDArray[np.int32] | None:
        """The ``(N,)`` int32 entity id per Gaussian, or ``None`` when the scene has none."""
        with self._read() as conn:
            self._scene_row(conn, scene_id)
            row = conn.execute(
                sa.select(m.gaussian_labels).where(m.gaussian_labels.c.scene_id == scene_id)
            ).first()
        if row is None:
            return None
        cols = row._mapping
        encoded = EncodedLabels(
            cols["count"], cols["dtype"], cols["codec"], cols["sha256"], bytes(cols["data"])
        )
        return decode_row(encoded, scene_id)

    def save_gaussian_labels(self, scene_id: str, labels: npt.ArrayLike) -> None:
        """Set (or replace) the per-Gaussian labels of a stored scene, atomically."""
        with self._write() as conn:
            self._scene_row(conn, scene_id)
            ids = (
                conn.execute(sa.select(m.entities.c.id).where(m.entities.c.scene_id == scene_id))
                .scalars()
                .all()
            )
            encoded = encode_labels(check_labels(labels, ids, scene_id))
            conn.execute(
                sa.delete(m.gaussian_labels).where(m.gaussian_labels.c.scene_id == scene_id)
            )
            conn.execute(sa.insert(m.gaussian_labels), [_labels_row(scene_id, encoded)])


# -- row conversion ----------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class _SceneRows:
    scene: dict[str, Any]
    entities: list[dict[str, Any]]
    attributes: list[dict[str, Any]]
    relations: list[dict[str, Any]]
    views: list[dict[str, Any]]
    masks: list[dict[str, Any]]

    def children(self) -> Sequence[tuple[sa.Table, list[dict[str, Any]]]]:
        """Child tables in foreign-key order."""
        return (
            (m.entities, self.entities),
            (m.entity_attributes, self.attributes),
            (m.relations, self.relations),
            (m.views, self.views),
            (m.masks, self.masks),
        )


def _scene_rows(graph: SceneGraph) -> _SceneRows:
    meta, sid = graph.meta, graph.scene_id
    scene = {
        "id": sid,
        "name": meta.name,
        "units": meta.units,
        "up_axis": meta.up_axis,
        "source": meta.source,
        "config_hash": meta.config_hash,
        "provenance": dict(meta.provenance),
        "created_at": datetime.now(UTC),
        "entity_count": len(graph.entities),
        "relation_count": len(graph.relations),
    }
    entities: list[dict[str, Any]] = []
    attributes: list[dict[str, Any]] = []
    for e in graph.entities:
        (cx, cy, cz), (x0, y0, z0), (x1, y1, z1) = e.centroid, e.bbox_min, e.bbox_max
        entities.append(
            {
                "scene_id": sid, "id": e.id, "external_id": e.external_id,
                "category": e.category, "caption": e.caption,
                "cx": cx, "cy": cy, "cz": cz,
                "min_x": x0, "min_y": y0, "min_z": z0, "max_x": x1, "max_y": y1, "max_z": z1,
                "point_count": e.point_count, "confidence": e.confidence,
            }
        )  # fmt: skip
        attributes.extend(
            {"scene_id": sid, "entity_id": e.id, "key": a.key, "value": a.value,
             "source": a.source.value}
            for a in e.attributes
        )  # fmt: skip
    relations = [
        {"scene_id": sid, "src": r.src, "dst": r.dst, "type": r.type.value,
         "evidence": _dumps(dict(r.evidence))}
        for r in graph.relations
    ]  # fmt: skip
    views = [
        {"scene_id": sid, "id": v.id, "name": v.name, "width": v.width, "height": v.height}
        for v in graph.views
    ]
    masks = [
        {"scene_id": sid, "view_id": k.view, "idx": k.index, "entity_id": k.entity,
         "label": k.label, "score": k.score}
        for k in graph.masks
    ]  # fmt: skip
    return _SceneRows(scene, entities, attributes, relations, views, masks)


def _delete_scene_rows(conn: Connection, scene_id: str) -> bool:
    """Delete a scene's rows child tables first (one range delete each, no per-row cascade).

    Returns whether the scene existed. The foreign keys still cascade, as a safety net.
    """
    for table in (m.relations, m.entity_attributes, m.masks, m.views, m.gaussian_labels,
                  m.query_log, m.entities):  # fmt: skip
        conn.execute(sa.delete(table).where(table.c.scene_id == scene_id))
    return conn.execute(sa.delete(m.scenes).where(m.scenes.c.id == scene_id)).rowcount > 0


def _insert_many(conn: Connection, table: sa.Table, rows: list[dict[str, Any]]) -> None:
    """Bulk insert of driver-ready rows (JSON already as text), below SQLAlchemy's row layer.

    SQLite: the driver's ``executemany``. PostgreSQL: ``COPY ... FROM STDIN`` through
    psycopg, on the same connection and transaction. Per-row parameter processing in
    SQLAlchemy costs more than the database's own work at 100k rows; table and column names
    come from the models, never from input.
    """
    if not rows:
        return
    prep = conn.dialect.identifier_preparer
    columns = list(rows[0])
    names = ", ".join(prep.quote(c) for c in columns)
    target = prep.format_table(table)
    if conn.dialect.name == "sqlite":
        marks = ", ".join(f":{c}" for c in columns)
        conn.exec_driver_sql(f"INSERT INTO {target} ({names}) VALUES ({marks})", rows)
        return
    dbapi: Any = conn.connection.dbapi_connection  # a psycopg (3) connection
    with dbapi.cursor() as cursor, cursor.copy(f"COPY {target} ({names}) FROM STDIN") as copy:
        for row in rows:
            copy.write_row(tuple(row.values()))


def _labels_row(scene_id: str, encoded: EncodedLabels) -> dict[str, Any]:
    return {
        "scene_id": scene_id,
        "count": encoded.count,
        "dtype": encoded.dtype,
        "codec": encoded.codec,
        "sha256": encoded.sha256,
        "data": encoded.data,
    }


def _attributes_by_entity(
    conn: Connection, scene_id: str, entity_id: int | None = None
) -> dict[int, list[Attribute]]:
    t = m.entity_attributes
    query = sa.select(t.c.entity_id, t.c.key, t.c.value, t.c.source).where(t.c.scene_id == scene_id)
    if entity_id is not None:
        query = query.where(t.c.entity_id == entity_id)
    out: dict[int, list[Attribute]] = {}
    for row in conn.execute(query):
        out.setdefault(row.entity_id, []).append(
            Attribute(row.key, row.value, AttributeSource(row.source))
        )
    return out


def _entity_from_row(row: sa.Row[Any], attributes: Sequence[Attribute]) -> Entity:
    return trusted_entity(
        id=row.id,
        category=row.category,
        centroid=(row.cx, row.cy, row.cz),
        bbox_min=(row.min_x, row.min_y, row.min_z),
        bbox_max=(row.max_x, row.max_y, row.max_z),
        external_id=row.external_id,
        caption=row.caption,
        point_count=row.point_count,
        confidence=row.confidence,
        attributes=tuple(attributes),
    )


def _summary(r: sa.Row[Any]) -> SceneSummary:
    return SceneSummary(
        scene_id=r.id,
        name=r.name,
        source=r.source,
        units=r.units,
        up_axis=r.up_axis,
        entity_count=r.entity_count,
        relation_count=r.relation_count,
        created_at=_aware(r.created_at),
        config_hash=r.config_hash,
    )


def _meta_from_row(row: sa.Row[Any]) -> SceneMeta:
    provenance: Mapping[str, str] = row.provenance or {}
    return SceneMeta(
        scene_id=row.id,
        name=row.name,
        units=row.units,
        up_axis=row.up_axis,
        source=row.source,
        config_hash=row.config_hash,
        provenance=tuple(provenance.items()),
        created_at=_aware(row.created_at),
    )


def _aware(value: datetime) -> datetime:
    """SQLite returns naive datetimes for what was written as UTC."""
    return value if value.tzinfo is not None else value.replace(tzinfo=UTC)


__all__ = ["GraphStore", "GraphStoreError", "IfExists", "SceneSummary", "open_store"]
