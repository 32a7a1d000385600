"""Alembic environment: migrates the store at the URL given by the caller.

The URL comes from, in order: a connection handed over by ``causalsplat db upgrade``
(``config.attributes["connection"]``), ``-x db=URL`` on the alembic command line, the
``CAUSALSPLAT_DB`` environment variable, ``sqlalchemy.url`` in alembic.ini.
"""

from __future__ import annotations

import os

from alembic import context

from graph_store._engine import create_store_engine
from graph_store.models import metadata

config = context.config
target_metadata = metadata


def _url() -> str:
    url = context.get_x_argument(as_dictionary=True).get("db") or os.environ.get("CAUSALSPLAT_DB")
    url = url or config.get_main_option("sqlalchemy.url")
    if not url:
        raise SystemExit("no database URL: pass -x db=URL or set CAUSALSPLAT_DB")
    return url


def _configure(connection: object) -> None:
    context.configure(
        connection=connection,
        target_metadata=target_metadata,
        render_as_batch=True,  # SQLite cannot ALTER most things; batch mode recreates tables
        compare_type=True,
        compare_server_default=True,
    )


def run_migrations_offline() -> None:
    context.configure(
        url=_url(),
        target_metadata=target_metadata,
        literal_binds=True,
        render_as_batch=True,
        dialect_opts={"paramstyle": "named"},
    )
    with context.begin_transaction():
        context.run_migrations()


def run_migrations_online() -> None:
    connection = config.attributes.get("connection")
    if connection is not None:
        _configure(connection)
        with context.begin_transaction():
            context.run_migrations()
        return
    engine = create_store_engine(_url())
    try:
        with engine.connect() as conn:
            _configure(conn)
            with context.begin_transaction():
                context.run_migrations()
    finally:
        engine.dispose()


if context.is_offline_mode():
    run_migrations_offline()
else:
    run_migrations_online()
