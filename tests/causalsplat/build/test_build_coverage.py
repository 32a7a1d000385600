"""The coverage check: a PLY and cameras from different captures are refused before the
expensive stages, with both shares in the message; matching ones pass."""

from __future__ import annotations

import dataclasses
import json
import shutil
from pathlib import Path

import pytest

from causalsplat import open_store
from causalsplat.build import BuildConfig, CoverageError, build_scene, read_scene_folder
from causalsplat.build.config import BuildConfigError
from causalsplat.build.coverage import measure_coverage
from causalsplat.field import FieldConfig
from causalsplat.io.types import Camera
from tests.causalsplat.test_cli_store import assert_one_line_error, run
from tests.conftest import shared_data_path

FAST = BuildConfig(field=FieldConfig(iterations=20))


def _moved(cameras: tuple[Camera, ...], metres: float) -> list[Camera]:
    """Each camera moved back along its viewing axis (negative: past the scene, which is
    then behind it)."""
    out = []
    for c in cameras:
        T = c.T_cam_world.copy()
        T[2, 3] += metres
        out.append(dataclasses.replace(c, T_cam_world=T))
    return out


def test_matching_inputs_are_covered_and_moved_cameras_are_not(tiny_folder: Path) -> None:
    folder = read_scene_folder(tiny_folder)
    here = measure_coverage(folder.gaussians.means, folder.cameras, folder.masks)
    assert here.seen > 0.8 and here.masked > 0.8 and here.sampled == folder.gaussians.n
    behind = measure_coverage(folder.gaussians.means, _moved(folder.cameras, -1e4),
                              folder.masks)  # fmt: skip
    assert behind.seen == 0.0 and behind.masked == 0.0
    # 10 km away the whole scene is seen, as a dot in the middle of every view
    far = measure_coverage(folder.gaussians.means, _moved(folder.cameras, 1e4), folder.masks)
    assert far.seen == 1.0 and far.masked < 0.05
    # no mask pixel anywhere: nothing to miss
    empty = [dataclasses.replace(m, masks=m.masks[:0], labels=None, scores=None)
             for m in folder.masks]  # fmt: skip
    assert measure_coverage(folder.gaussians.means, folder.cameras, empty).masked == 1.0


def test_a_sample_of_the_gaussians_measures_the_same_shares(tiny_folder: Path) -> None:
    folder = read_scene_folder(tiny_folder)
    full = measure_coverage(folder.gaussians.means, folder.cameras, folder.masks)
    part = measure_coverage(folder.gaussians.means, folder.cameras, folder.masks,
                            max_points=1000)  # fmt: skip
    assert part.sampled <= 1000
    # the cells grow with a smaller sample, so it still passes the default threshold
    assert abs(part.seen - full.seen) < 0.05 and 0.5 < part.masked <= full.masked + 0.05


def test_thresholds_are_checked() -> None:
    with pytest.raises(BuildConfigError, match=r"min_masked must be in \[0, 1\], got 1.5"):
        BuildConfig(min_masked=1.5)
    with pytest.raises(BuildConfigError, match=r"min_seen must be in \[0, 1\], got True"):
        BuildConfig(min_seen=True)  # type: ignore[arg-type]


def test_build_refuses_cameras_of_another_capture(tiny_folder: Path, tmp_path: Path) -> None:
    with pytest.raises(CoverageError, match=r"see 100\.0% of the Gaussians .* and 0\.\d% of"):
        scene = tmp_path / "moved"
        shutil.copytree(tiny_folder, scene)
        from causalsplat.io import read_colmap_model, write_colmap_model

        model = read_colmap_model(scene / "sparse" / "0")
        moved = tuple(_moved(model.cameras, 1e4))
        write_colmap_model(scene / "sparse" / "0", dataclasses.replace(model, cameras=moved))
        build_scene(scene, config=FAST, cache_dir=False)
    off = dataclasses.replace(FAST, min_seen=0.0, min_masked=0.0)
    # checked off, the build goes on and makes whatever a dot in each view gives
    result = build_scene(scene, config=off, cache_dir=False)
    assert result.coverage is not None and result.coverage.masked < 0.05


def test_the_real_inria_ply_with_unrelated_cameras_is_refused(
    tiny_folder: Path, tmp_path: Path
) -> None:
    ply = shared_data_path("inria_3dgs_ply_sample", "point_cloud_iter7000.ply")
    scene = tmp_path / "mixed"
    shutil.copytree(tiny_folder, scene, ignore=shutil.ignore_patterns("point_cloud.ply", "gt"))
    shutil.copy(ply, scene / "point_cloud.ply")  # a real capture's Gaussians, our cameras
    db_path = tmp_path / "m.db"
    db = f"sqlite:///{db_path}"
    with open_store(db) as store:
        store.graph_store.initialise()  # an empty store, as the refused build must leave it
    before = db_path.read_bytes()
    refused = run("build", str(scene), "--no-cache", db=db, check=False)
    assert_one_line_error(refused, "do not look like one capture")
    line = refused.stderr
    assert "of the Gaussians (at least 5% needed)" in line and "(at least 50% needed)" in line
    assert db_path.read_bytes() == before
    config = tmp_path / "off.json"
    config.write_text(json.dumps({"min_seen": 0, "min_masked": 0, "field": {"iterations": 5}}))
    built = json.loads(run("build", str(scene), "--no-cache", "--config", str(config), "--json",
                           db=db).stdout)  # fmt: skip
    assert built["coverage"]["masked"] < 0.5 and built["coverage"]["sampled"] == 9080


def test_build_json_reports_the_coverage(tiny_folder: Path) -> None:
    doc = build_scene(tiny_folder, config=FAST, cache_dir=False).to_json()
    assert doc["coverage"]["seen"] > 0.8 and doc["coverage"]["masked"] > 0.8
