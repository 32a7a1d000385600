"""A scene folder whose COLMAP cameras have lens distortion, built through the CLI."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from causalsplat import open_store
from tests.causalsplat.io.test_io_colmap_distortion import distort
from tests.causalsplat.test_cli_store import assert_one_line_error, run


def test_build_refuses_a_distorted_model_and_builds_it_when_allowed(
    tiny_folder: Path, tmp_path: Path
) -> None:
    scene = tmp_path / "scene"
    shutil.copytree(tiny_folder, scene)
    distort(scene)
    db_path = tmp_path / "d.db"
    db = f"sqlite:///{db_path}"
    with open_store(db) as store:
        store.graph_store.initialise()  # an empty store, as the refused build must leave it
    before = db_path.read_bytes()
    config = tmp_path / "fast.json"
    config.write_text(json.dumps({"field": {"iterations": 20}}))
    refused = run("build", str(scene), "--config", str(config), "--no-cache", db=db, check=False)
    assert_one_line_error(refused, "(OPENCV, largest coefficient 0.02)")
    assert "--allow-distortion" in refused.stderr and "Traceback" not in refused.stderr
    assert db_path.read_bytes() == before
    built = run("build", str(scene), "--config", str(config), "--no-cache",
                "--allow-distortion", "--json", db=db)  # fmt: skip
    doc = json.loads(built.stdout)
    assert doc["entities"] > 0
    (warning,) = [w for w in doc["warnings"] if "lens distortion dropped" in w]
    assert "OPENCV" in warning and "colmap image_undistorter" in warning
    plain = run("build", str(scene), "--config", str(config), "--no-cache", "--allow-distortion",
                "--scene", "again", db=db)  # fmt: skip
    assert "causalsplat: warning: lens distortion dropped" in plain.stderr
