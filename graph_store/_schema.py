"""Schema version checks and the creation of a new, empty store.

The schema is owned by the Alembic revisions in ``migrations/``. A brand-new database is
created from :data:`graph_store.models.metadata` and stamped with
:data:`SCHEMA_REVISION` in one transaction (a test holds that this equals migrating an
empty database to head). An existing database must be at :data:`SCHEMA_REVISION`;
otherwise the store refuses to touch it and says how to migrate it.
"""

from __future__ import annotations

import sqlalchemy as sa
from sqlalchemy.engine import Connection, Engine

from graph_store._engine import WRITE, describe_url
from graph_store.errors import SchemaVersionError
from graph_store.models import metadata

#: The Alembic revision this code reads and writes. Kept equal to the head of
#: ``migrations/versions`` by a test.
SCHEMA_REVISION = "0001"

_VERSION_TABLE = "alembic_version"


def current_revision(conn: Connection) -> str | None:
    """The Alembic revision stamped in the database, or ``None`` when unstamped."""
    if not sa.inspect(conn).has_table(_VERSION_TABLE):
        return None
    rows = conn.execute(sa.text(f"SELECT version_num FROM {_VERSION_TABLE}")).scalars().all()
    if len(rows) > 1:
        raise SchemaVersionError(f"the database has several Alembic heads: {sorted(rows)}")
    return rows[0] if rows else None


def ensure_schema(engine: Engine, *, create: bool) -> None:
    """Check the schema revision; create the schema in an empty database when allowed."""
    with engine.connect() as conn:
        revision = current_revision(conn)
        tables = set(sa.inspect(conn).get_table_names())
    where = describe_url(engine.url)
    if revision == SCHEMA_REVISION:
        return
    if revision is not None:
        raise SchemaVersionError(
            f"the store at {where} is at schema revision {revision!r}, this version of "
            f"causalsplat needs {SCHEMA_REVISION!r}: run `causalsplat db upgrade --db URL`"
        )
    ours = set(metadata.tables)
    if tables & ours:
        raise SchemaVersionError(
            f"the database at {where} has store tables ({', '.join(sorted(tables & ours))}) "
            "but no schema revision: run `causalsplat db upgrade --db URL`"
        )
    if not create:
        raise SchemaVersionError(
            f"the database at {where} holds no store: run `causalsplat db upgrade --db URL`"
        )
    _create_schema(engine)


def _create_schema(engine: Engine) -> None:
    version = sa.Table(
        _VERSION_TABLE,
        sa.MetaData(),
        sa.Column("version_num", sa.String(32), primary_key=True),
    )
    with engine.connect().execution_options(**WRITE) as conn, conn.begin():
        if current_revision(conn) is not None:  # another process created it meanwhile
            return
        metadata.create_all(conn)
        version.create(conn)
        conn.execute(version.insert().values(version_num=SCHEMA_REVISION))
