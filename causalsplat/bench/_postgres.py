"""A scratch PostgreSQL database for a benchmark run, made and dropped around it."""

from __future__ import annotations

import os
import uuid
from collections.abc import Iterator
from contextlib import contextmanager


@contextmanager
def scratch_database() -> Iterator[str | None]:
    """The URL of a new database on the server of ``$CAUSALSPLAT_BENCH_POSTGRES_URL`` (else
    ``$CAUSALSPLAT_TEST_POSTGRES_URL``: an admin URL), dropped on exit; ``None`` without one."""
    admin_url = os.environ.get("CAUSALSPLAT_BENCH_POSTGRES_URL") or os.environ.get(
        "CAUSALSPLAT_TEST_POSTGRES_URL"
    )
    if not admin_url:
        yield None
        return
    import sqlalchemy as sa

    url = sa.engine.make_url(admin_url)
    name = f"cs_bench_{uuid.uuid4().hex[:10]}"
    admin = sa.create_engine(url, isolation_level="AUTOCOMMIT")
    try:
        with admin.connect() as conn:
            conn.execute(sa.text(f'CREATE DATABASE "{name}"'))
        yield url.set(database=name).render_as_string(hide_password=False)
    finally:
        with admin.connect() as conn:
            conn.execute(sa.text(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)'))
        admin.dispose()
