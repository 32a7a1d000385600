"""The build pipeline on the synthetic tiny scene: outputs, caching, config, errors."""

from __future__ import annotations

import dataclasses
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from causalsplat import open_store
from causalsplat.build import (
    BuildConfig,
    BuildConfigError,
    BuildResult,
    SceneFolderFormatError,
    build_scene,
)
from causalsplat.field import FieldConfig
from causalsplat.instances import InstanceConfig
from causalsplat.io import read_colmap_model, read_gaussian_ply, write_colmap_model, write_ply

FAST = BuildConfig(field=FieldConfig(iterations=60))


@pytest.fixture(scope="module")
def cache(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("stage-cache")


@pytest.fixture(scope="module")
def built(tiny_folder: Path, cache: Path) -> BuildResult:
    return build_scene(tiny_folder, scene_id="tiny", config=FAST, cache_dir=cache)


def test_build_produces_a_consistent_graph(built: BuildResult, tiny_folder: Path) -> None:
    g = built.graph
    gt_objects = json.loads((tiny_folder / "objects.json").read_text())["objects"]
    gt_categories = {o["label"] for o in gt_objects}
    assert g.scene_id == "tiny" and g.meta.source == "build" and g.meta.config_hash
    assert len(g.entities) >= 3
    # every category comes from the mask labels (GT categories or the fragment label)
    assert {e.category for e in g.entities} <= gt_categories | {"object"}
    assert {"floor", "wall"} <= {e.category for e in g.entities}
    labels = built.gaussian_labels
    assert labels.shape == (built.n_gaussians,) and labels.dtype == np.int32
    ids = {e.id for e in g.entities}
    assert set(np.unique(labels[labels >= 0]).tolist()) == ids
    for e in g.entities:
        own = int((labels == e.id).sum())
        assert e.point_count == own > 0
        assert all(lo <= c <= hi for lo, c, hi in zip(e.bbox_min, e.centroid, e.bbox_max))
    assert len(g.views) == built.n_views == 12
    assert len(g.masks) == sum(1 for _ in g.masks) and all(
        m.entity is None or m.entity in ids for m in g.masks
    )
    assert g.relations, "a room has spatial relations"
    assert dict(g.meta.provenance)["point_cloud.ply"]
    assert built.quality is not None and 0 < built.quality.mean_best_iou <= 1
    names = [s.name for s in built.stages]
    assert names == ["load", "rasterize", "field", "instances", "graph"]


def test_a_rerun_reuses_the_cache_and_later_changes_keep_earlier_stages(
    built: BuildResult, tiny_folder: Path, cache: Path
) -> None:
    again = build_scene(tiny_folder, scene_id="tiny", config=FAST, cache_dir=cache)
    assert [(s.name, s.cached) for s in again.stages] == [
        ("load", False), ("field", True), ("instances", True), ("graph", False)
    ]  # fmt: skip
    assert again.graph == built.graph
    np.testing.assert_array_equal(again.gaussian_labels, built.gaussian_labels)
    changed = dataclasses.replace(FAST, instances=InstanceConfig(min_cluster_size=2))
    third = build_scene(tiny_folder, scene_id="tiny", config=changed, cache_dir=cache)
    assert [(s.name, s.cached) for s in third.stages][1:3] == [
        ("field", True), ("instances", False)
    ]  # fmt: skip


def test_a_changed_mask_file_invalidates_the_field(tiny_folder: Path, tmp_path: Path,
                                                   cache: Path) -> None:  # fmt: skip
    folder = tmp_path / "copy"
    shutil.copytree(tiny_folder, folder)
    first = sorted((folder / "masks").glob("*.npz"))[0]
    data = dict(np.load(first))
    data["masks"] = data["masks"][:-1]
    for key in ("labels", "scores"):
        if key in data:
            data[key] = data[key][:-1]
    np.savez(first, **data)
    out = build_scene(folder, config=FAST, cache_dir=cache)
    assert ("field", False) in [(s.name, s.cached) for s in out.stages]
    assert out.graph.scene_id == "synth-tiny-0"  # declared by the folder's queries.json


def test_no_cache_and_deterministic(built: BuildResult, tiny_folder: Path) -> None:
    fresh = build_scene(tiny_folder, scene_id="tiny", config=FAST, cache_dir=False)
    assert not any(s.cached for s in fresh.stages)
    assert fresh.graph == built.graph
    np.testing.assert_array_equal(fresh.gaussian_labels, built.gaussian_labels)


def test_store_build_persists_graph_and_labels(tiny_folder: Path, tmp_path: Path,
                                               cache: Path) -> None:  # fmt: skip
    with open_store(f"sqlite:///{tmp_path / 's.db'}") as store:
        scene = store.build(tiny_folder, scene_id="tiny", config=FAST, cache_dir=cache)
        assert scene.build_report is not None
        again = store.scene("tiny")
        assert again.graph == scene.graph
        labels = again.gaussian_labels()
        assert labels is not None
        np.testing.assert_array_equal(labels, scene.build_report.gaussian_labels)
        answer = again.ask("where can I wash my hands?")
        assert answer.entity_ids and all(
            again.get_entity(i).category == "sink" for i in answer.entity_ids
        )


def test_config_file_round_trip_and_errors(tmp_path: Path) -> None:
    path = tmp_path / "c.json"
    path.write_text(json.dumps({"max_views": 4, "field": {"iterations": 7}}))
    config = BuildConfig.from_file(path)
    assert config.max_views == 4 and config.field.iterations == 7
    assert BuildConfig.from_json(config.to_json() | {"edges": {"tau_v": 0.3}}).max_views == 4
    for doc, match in [
        ({"fields": {}}, r"unknown key\(s\) \['fields'\]"),
        ({"field": {"iters": 3}}, r"field: unknown key\(s\) \['iters'\]"),
        ({"field": {"iterations": -3}}, "FieldConfig.iterations"),
        ({"field": 3}, "expected a JSON object"),
        ({"max_views": 0}, "max_views"),
        ({"up_axis": "w"}, "up_axis"),
    ]:
        path.write_text(json.dumps(doc))
        with pytest.raises(BuildConfigError, match=match):
            BuildConfig.from_file(path)
    path.write_text("{not json")
    with pytest.raises(BuildConfigError, match="cannot read"):
        BuildConfig.from_file(path)


def test_a_missing_folder_is_a_typed_error(tmp_path: Path) -> None:
    with pytest.raises(SceneFolderFormatError):
        build_scene(tmp_path / "nope", cache_dir=False)


@pytest.mark.parametrize("factor", [1e-3, 1e3], ids=["kilometres", "millimetres"])
def test_scenes_in_millimetres_and_kilometres(tiny_folder: Path, tmp_path: Path,
                                              factor: float) -> None:  # fmt: skip
    """The same room in other units (coordinates x 1e-3: kilometres, x 1e3: millimetres):
    with the near plane scaled along it builds the same entities; with the default near
    plane (0.01 units) too, the build lowering it for the kilometre room and saying so."""
    folder = tmp_path / "scaled"
    shutil.copytree(tiny_folder, folder)
    ply = read_gaussian_ply(folder / "point_cloud.ply")
    s = ply.scene
    scaled = dataclasses.replace(
        s, means=s.means * factor, log_scales=s.log_scales + np.float32(np.log(factor))
    )
    write_ply(folder / "point_cloud.ply", scaled)
    model = read_colmap_model(folder / "sparse" / "0")
    cams = []
    for c in model.cameras:
        T = c.T_cam_world.copy()
        T[:3, 3] *= factor
        cams.append(dataclasses.replace(c, T_cam_world=T))
    write_colmap_model(folder / "sparse" / "0", dataclasses.replace(model, cameras=tuple(cams)))
    raster = dataclasses.replace(FAST.raster, near=FAST.raster.near * factor, far=1e10 * factor)
    cfg = dataclasses.replace(FAST, raster=raster)
    base = build_scene(tiny_folder, config=FAST, cache_dir=False)
    out = build_scene(folder, config=cfg, cache_dir=False)
    assert [e.category for e in out.graph.entities] == [e.category for e in base.graph.entities]
    for a, b in zip(out.graph.entities, base.graph.entities, strict=True):
        np.testing.assert_allclose(a.centroid, np.array(b.centroid) * factor, rtol=1e-3,
                                   atol=1e-6 * factor)  # fmt: skip
    default = build_scene(folder, config=FAST, cache_dir=False)
    assert [e.category for e in default.graph.entities] == [e.category for e in base.graph.entities]
    assert any(w.startswith("raster.near lowered") for w in default.warnings) == (factor < 1)


@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="needs Linux /proc")
def test_peak_memory_is_the_process_own_not_its_parents() -> None:
    """``ru_maxrss`` survives fork and exec; a build started by a big process reports its own."""
    import subprocess
    import sys

    from causalsplat.build.pipeline import _peak_rss_mib

    ballast = np.ones(1024 * 1024 * 1024 // 8)  # 1 GiB, touched
    parent = _peak_rss_mib()
    code = "from causalsplat.build.pipeline import _peak_rss_mib; print(_peak_rss_mib())"
    child = float(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                                 check=True).stdout)  # fmt: skip
    del ballast
    assert parent >= 1024 and 0 < child < parent - 900
