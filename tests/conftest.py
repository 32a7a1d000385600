"""Shared fixtures: database URLs (SQLite and a real PostgreSQL) and the shared data folder.

PostgreSQL: set ``CAUSALSPLAT_TEST_POSTGRES_URL`` to an admin URL of a running server
(``.ci/run`` starts one and sets it). Each test gets a database of its own, created and
dropped around it. Without the variable the PostgreSQL cases are skipped locally; under
CI (``CI=true``) they fail instead, so CI can never pass without running them.
"""

from __future__ import annotations

import os
import uuid
from collections.abc import Iterator
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parent.parent
SHARED_DATA = REPO_ROOT.parent / "shared" / "data"
POSTGRES_ENV = "CAUSALSPLAT_TEST_POSTGRES_URL"
#: Seconds a test waits for a command it starts before giving up on it: a bound against a
#: hung child, not a speed check (CI machines are shared and slow at times).
COMMAND_TIMEOUT_S = float(os.environ.get("CAUSALSPLAT_TEST_COMMAND_TIMEOUT_S", "900"))


def shared_data_path(*parts: str) -> Path:
    """Path under ``../shared/data``; skips the calling test when it is absent."""
    path = SHARED_DATA.joinpath(*parts)
    if not path.exists():
        pytest.skip(f"shared data not present: {path}")
    return path


@pytest.fixture
def shared_data() -> Path:
    return shared_data_path()


def _postgres_admin_url() -> str:
    url = os.environ.get(POSTGRES_ENV)
    if url:
        return url
    if os.environ.get("CI", "").lower() == "true":
        pytest.fail(f"{POSTGRES_ENV} is not set: CI must run the PostgreSQL tests")
    pytest.skip(f"no PostgreSQL server ({POSTGRES_ENV} not set)")


@pytest.fixture
def postgres_url() -> Iterator[str]:
    """URL of a fresh, empty PostgreSQL database, dropped after the test."""
    import sqlalchemy as sa

    admin_url = sa.engine.make_url(_postgres_admin_url())
    name = f"cs_test_{uuid.uuid4().hex[:12]}"
    admin = sa.create_engine(admin_url, isolation_level="AUTOCOMMIT")
    try:
        with admin.connect() as conn:
            conn.execute(sa.text(f'CREATE DATABASE "{name}"'))
        yield admin_url.set(database=name).render_as_string(hide_password=False)
    finally:
        with admin.connect() as conn:
            conn.execute(sa.text(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)'))
        admin.dispose()


@pytest.fixture
def sqlite_url(tmp_path: Path) -> str:
    return f"sqlite:///{tmp_path / 'store.db'}"


@pytest.fixture(params=["sqlite", pytest.param("postgres", marks=pytest.mark.postgres)])
def db_url(request: pytest.FixtureRequest, tmp_path: Path) -> str:
    """A fresh database URL, once on SQLite and once on PostgreSQL."""
    if request.param == "sqlite":
        return f"sqlite:///{tmp_path / 'store.db'}"
    return str(request.getfixturevalue("postgres_url"))
