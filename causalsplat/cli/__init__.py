"""The ``causalsplat`` command line (DESIGN §10).

A thin layer over the Python API: every command takes ``--db URL`` and ``--json``;
any library error becomes one line on stderr and a non-zero exit status.
Command groups live in private modules, each registering its commands on :data:`cli`.
"""

from __future__ import annotations

from causalsplat.cli._app import cli, main

# Each module registers its commands on `cli` when imported.
from causalsplat.cli import _store_cmds  # noqa: F401  isort: skip
from causalsplat.cli import _bench_cmds  # noqa: F401  isort: skip
from causalsplat.cli import _demo_cmd  # noqa: F401  isort: skip
from causalsplat.cli import _scene_cmds  # noqa: F401  isort: skip
from causalsplat.cli import _query_cmds  # noqa: F401  isort: skip
from causalsplat.cli import _reason_cmds  # noqa: F401  isort: skip
from causalsplat.cli import _build_cmd  # noqa: F401  isort: skip
from causalsplat.cli import _build_many_cmd  # noqa: F401  isort: skip
from causalsplat.cli import _masks_cmds  # noqa: F401  isort: skip
from causalsplat.cli import _serve_cmd  # noqa: F401  isort: skip

__all__ = ["cli", "main"]
