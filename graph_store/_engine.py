"""Engine creation: URL checks, SQLite pragmas and transaction modes, PostgreSQL options.

SQLite is configured for a store that several processes share:

- ``journal_mode=WAL``: readers never block the writer and see the last committed state;
- ``foreign_keys=ON``: the cascades and references of the schema are enforced;
- ``busy_timeout``: a writer waits for another writer's lock instead of failing at once;
- ``synchronous=NORMAL``: with WAL, a killed process never corrupts the database or
  exposes a half-written transaction (a power cut may lose the last commits only).

The pysqlite driver's own transaction handling is switched off and SQLAlchemy's ``begin``
emits ``BEGIN`` itself: ``BEGIN IMMEDIATE`` for write transactions (the write lock is taken
up front, so two writers queue on the busy timeout instead of dead-locking on a lock
upgrade), plain ``BEGIN`` for reads.
"""

from __future__ import annotations

import os
import re
from typing import Any

import sqlalchemy as sa
from sqlalchemy import event
from sqlalchemy.engine import URL, Connection, Engine, make_url
from sqlalchemy.pool import StaticPool

from graph_store.errors import StoreConnectionError

#: Seconds a SQLite writer waits for another writer's lock before giving up.
SQLITE_BUSY_TIMEOUT_S = 30.0
#: Page cache per SQLite connection, in KiB (the default 2 MiB thrashes on bulk writes).
SQLITE_CACHE_KIB = 65536
#: Seconds to wait for a PostgreSQL server to accept a connection.
POSTGRES_CONNECT_TIMEOUT_S = 10

WRITE = {"graph_store_write": True}


_SCHEME = re.compile(r"[A-Za-z][A-Za-z0-9+.-]*:")


def as_url(url: str | os.PathLike[str] | URL) -> str | URL:
    """A database URL as given, or a plain file path (no ``scheme:``) as the URL of that
    SQLite file.

    >>> as_url("demo-out/demo.db")
    'sqlite:///demo-out/demo.db'
    >>> as_url("/data/scenes.db")
    'sqlite:////data/scenes.db'
    >>> as_url("postgresql+psycopg://me@host/scenes")
    'postgresql+psycopg://me@host/scenes'
    """
    if isinstance(url, URL):
        return url
    text = os.fspath(url)
    if not text.strip() or _SCHEME.match(text):
        return text
    return f"sqlite:///{text}"


def parse_url(url: str | os.PathLike[str] | URL) -> URL:
    """Parse a database URL (or a SQLite file path, see :func:`as_url`), raising
    :class:`StoreConnectionError` when it is malformed."""
    url = as_url(url)
    if isinstance(url, str) and not url.strip():
        raise StoreConnectionError(
            "the database URL is empty: use sqlite:///PATH or postgresql+psycopg://USER@HOST/DB"
        )
    try:
        parsed = make_url(url)
    except (sa.exc.ArgumentError, ValueError) as exc:
        raise StoreConnectionError(f"malformed database URL {str(url)!r}: {exc}") from exc
    backend = parsed.get_backend_name()
    if backend not in ("sqlite", "postgresql"):
        raise StoreConnectionError(
            f"unsupported database {backend!r} in {parsed.render_as_string()!r}: "
            "use sqlite:///PATH or postgresql+psycopg://USER@HOST/DB"
        )
    return parsed


def missing_sqlite_file(url: str | URL) -> str | None:
    """The path of a file-backed SQLite URL whose file does not exist (else ``None``).

    >>> missing_sqlite_file("sqlite:///no/such/dir/store.db")
    'no/such/dir/store.db'
    >>> missing_sqlite_file("sqlite://") is None
    True
    """
    parsed = parse_url(url)
    if parsed.get_backend_name() != "sqlite":
        return None
    database = parsed.database
    if (
        database in (None, "", ":memory:")
        or parsed.query.get("uri")
        or database.startswith("file:")
    ):
        return None
    return None if os.path.exists(database) else database


def on_read_only_filesystem(url: str | URL) -> bool:
    """Whether a file-backed SQLite URL's file exists on a filesystem mounted read-only
    (a snapshot, a shared dataset volume): it can then only be read as immutable."""
    parsed = parse_url(url)
    database = parsed.database
    if parsed.get_backend_name() != "sqlite" or missing_sqlite_file(parsed) is not None:
        return False
    if database in (None, "", ":memory:") or database.startswith("file:"):
        return False
    try:
        return bool(os.statvfs(database).f_flag & os.ST_RDONLY)
    except (OSError, AttributeError):
        return False


def create_store_engine(url: str | URL, *, echo: bool = False, read_only: bool = False) -> Engine:
    """Create an engine for a store URL with the settings described in the module doc.

    ``read_only`` (SQLite files only): open the file as immutable (``mode=ro&immutable=1``),
    for a store on a read-only filesystem, where nobody can be writing it and SQLite could
    not create the WAL's shared-memory file a normal reader needs.
    """
    parsed = parse_url(url)
    try:
        if parsed.get_backend_name() == "sqlite":
            if read_only and parsed.database not in (None, "", ":memory:"):
                return _immutable_sqlite_engine(parsed, echo=echo)
            return _sqlite_engine(parsed, echo=echo)
        return _postgres_engine(parsed, echo=echo)
    except ImportError as exc:
        raise StoreConnectionError(
            f"no driver for {parsed.drivername!r}: {exc}. "
            "For PostgreSQL install it with: pip install 'causalsplat[postgres]'"
        ) from exc


def _sqlite_engine(url: URL, *, echo: bool) -> Engine:
    in_memory = url.database in (None, "", ":memory:")
    kwargs: dict[str, Any] = {"connect_args": {"timeout": SQLITE_BUSY_TIMEOUT_S}}
    if in_memory:
        kwargs.update(poolclass=StaticPool)
        kwargs["connect_args"]["check_same_thread"] = False
    engine = sa.create_engine(url, echo=echo, **kwargs)

    @event.listens_for(engine, "connect")
    def _on_connect(dbapi_conn: Any, _record: Any) -> None:
        dbapi_conn.isolation_level = None  # SQLAlchemy's begin event emits BEGIN
        cursor = dbapi_conn.cursor()
        try:
            if not in_memory:
                cursor.execute("PRAGMA journal_mode=WAL")
                cursor.execute("PRAGMA synchronous=NORMAL")
            cursor.execute("PRAGMA foreign_keys=ON")
            cursor.execute(f"PRAGMA cache_size=-{SQLITE_CACHE_KIB}")
            cursor.execute(f"PRAGMA busy_timeout={int(SQLITE_BUSY_TIMEOUT_S * 1000)}")
        finally:
            cursor.close()

    @event.listens_for(engine, "begin")
    def _on_begin(conn: Connection) -> None:
        write = conn.get_execution_options().get("graph_store_write", False)
        conn.exec_driver_sql("BEGIN IMMEDIATE" if write else "BEGIN")

    return engine


def _immutable_sqlite_engine(url: URL, *, echo: bool) -> Engine:
    import sqlite3
    from urllib.parse import quote

    assert url.database is not None
    target = f"file:{quote(os.path.abspath(url.database))}?mode=ro&immutable=1"

    def connect() -> sqlite3.Connection:
        conn = sqlite3.connect(target, uri=True, check_same_thread=False)
        conn.isolation_level = None  # SQLAlchemy's begin event emits BEGIN
        conn.execute("PRAGMA foreign_keys=ON")
        return conn

    engine = sa.create_engine("sqlite://", creator=connect, echo=echo)

    @event.listens_for(engine, "begin")
    def _on_begin(conn: Connection) -> None:
        conn.exec_driver_sql("BEGIN")

    return engine


def _postgres_engine(url: URL, *, echo: bool) -> Engine:
    if url.drivername == "postgresql":
        url = url.set(drivername="postgresql+psycopg")
    connect_args: dict[str, Any] = {}
    if "connect_timeout" not in url.query:
        connect_args["connect_timeout"] = POSTGRES_CONNECT_TIMEOUT_S
    return sa.create_engine(url, echo=echo, pool_pre_ping=True, connect_args=connect_args)


def describe_url(url: str | os.PathLike[str] | URL) -> str:
    """The URL as text with any password hidden, for messages."""
    try:
        return make_url(as_url(url)).render_as_string(hide_password=True)
    except (sa.exc.ArgumentError, ValueError):
        return "<malformed URL>"
