"""Schema migrations of a store, run in-process through Alembic (``causalsplat db ...``)."""

from __future__ import annotations

from alembic import command
from alembic.config import Config
from alembic.script import ScriptDirectory

from graph_store._engine import (
    WRITE,
    create_store_engine,
    describe_url,
    missing_sqlite_file,
    on_read_only_filesystem,
)
from graph_store._schema import current_revision
from graph_store.errors import StoreConnectionError, StoreNotFoundError


def alembic_config(db_url: str | None = None) -> Config:
    """An Alembic config pointing at the packaged ``migrations`` scripts."""
    from migrations import SCRIPT_LOCATION

    config = Config()
    config.set_main_option("script_location", str(SCRIPT_LOCATION))
    if db_url:
        config.set_main_option("sqlalchemy.url", db_url.replace("%", "%%"))
    return config


def head_revision() -> str:
    head = ScriptDirectory.from_config(alembic_config()).get_current_head()
    assert head is not None, "the migrations folder has no revision"
    return head


def _run(db_url: str, action: str, revision: str) -> tuple[str | None, str | None]:
    import sqlalchemy as sa

    engine = create_store_engine(db_url)
    try:
        with engine.connect().execution_options(**WRITE) as conn:
            before = current_revision(conn)
            conn.commit()
            config = alembic_config()
            config.attributes["connection"] = conn
            getattr(command, action)(config, revision)
            conn.commit()
            after = current_revision(conn)
            conn.commit()
        return before, after
    except sa.exc.DatabaseError as exc:  # OperationalError, "file is not a database", ...
        reason = str(exc.orig).strip().splitlines()[0] if exc.orig else str(exc)
        raise StoreConnectionError(f"cannot migrate the store: {reason}") from exc
    finally:
        engine.dispose()


def upgrade(db_url: str, revision: str = "head") -> tuple[str | None, str | None]:
    """Migrate up to ``revision``; returns the revisions before and after."""
    return _run(db_url, "upgrade", revision)


def downgrade(db_url: str, revision: str) -> tuple[str | None, str | None]:
    """Migrate down to ``revision`` (``"base"``: drop the whole schema)."""
    return _run(db_url, "downgrade", revision)


def current(db_url: str) -> str | None:
    """The store's schema revision (``None``: no schema); never creates a database."""
    import sqlalchemy as sa

    missing = missing_sqlite_file(db_url)
    if missing is not None:
        raise StoreNotFoundError(f"no store at {describe_url(db_url)}: {missing} does not exist")
    engine = create_store_engine(db_url, read_only=on_read_only_filesystem(db_url))
    try:
        with engine.connect() as conn:
            return current_revision(conn)
    except sa.exc.DatabaseError as exc:
        reason = str(exc.orig).strip().splitlines()[0] if exc.orig else str(exc)
        raise StoreConnectionError(
            f"cannot read the store at {describe_url(db_url)}: {reason}"
        ) from exc
    finally:
        engine.dispose()
