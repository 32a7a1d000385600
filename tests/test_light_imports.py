"""The query path stays light: importing it (and using the store) never imports torch."""

from __future__ import annotations

import subprocess
import sys

from tests.conftest import REPO_ROOT

SCRIPT = """
import sys
import graph_store, queries, causalsplat
import causalsplat.api, causalsplat.cli, causalsplat.objects, graph_store.repository
import causalsplat.build, causalsplat.field, causalsplat.instances, causalsplat.graph.nodes
from causalsplat import open_store
with open_store("sqlite://") as store:
    store.scenes()
heavy = sorted(m for m in ("torch", "hdbscan", "plyfile", "openai") if m in sys.modules)
print(",".join(heavy))
"""


def test_light_packages_do_not_import_torch() -> None:
    proc = subprocess.run(
        [sys.executable, "-c", SCRIPT], capture_output=True, text=True, cwd=REPO_ROOT, check=True
    )
    assert proc.stdout.strip() == "", f"heavy modules imported: {proc.stdout.strip()}"
