"""The ScanNet adapter on the real scene0000_00 (skipped when the shared data is absent)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from causalsplat.io import read_colmap_model, read_gaussian_ply
from causalsplat.masks import id_map_from_masks, read_masks
from causalsplat.render.functional import render_ids
from causalsplat.scannet import ScanNetFormatError, load_scannet
from causalsplat.scannet.cameras import real_cameras, walk_cameras
from causalsplat.scannet.language import load_utterances
from causalsplat.scannet.prepare import ScanNetConfig, gaussians_from_vertices, prepare_scannet
from tests.conftest import shared_data_path

pytestmark = pytest.mark.shared_data

N_VERTICES = 81_369
N_OBJECTS = 67


@pytest.fixture(scope="module")
def src() -> Path:
    return shared_data_path("scannet_scene0000_00")


@pytest.fixture(scope="module")
def raw_labels(src: Path) -> np.ndarray:
    path = src / "mmdet3d_votenet_format" / "scene0000_00_ins_label_all.npy"
    return np.load(path).astype(np.int64)


@pytest.fixture(scope="module")
def prepared(src: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("scannet") / "scene0000_00"
    prepare_scannet(src, out, n_walk_views=2)
    return out


def test_source_counts_and_labels(src: Path, raw_labels: np.ndarray) -> None:
    source = load_scannet(src)
    assert source.xyz.shape == (N_VERTICES, 3) and len(source.objects) == N_OBJECTS
    np.testing.assert_array_equal(source.instance, raw_labels - 1)
    assert source.instance.min() == -1 and source.instance.max() == N_OBJECTS - 1
    for obj in source.objects:  # the object table agrees with the labelled vertices
        pts = source.xyz[source.instance == obj.id]
        centre = (pts.min(axis=0) + pts.max(axis=0)) / 2
        np.testing.assert_allclose(centre, obj.center, atol=1e-4)
        np.testing.assert_allclose(pts.max(axis=0) - pts.min(axis=0), obj.size, atol=1e-4)


def test_utterances(src: Path) -> None:
    utterances = load_utterances(load_scannet(src))
    assert len(utterances) == 86  # 70 Sr3D + 11 Nr3D + 5 ScanRefer, no exact duplicates
    prefixes = {u.id.split("-")[0] for u in utterances}
    assert prefixes == {"sr3d", "nr3d", "scanrefer"}
    assert sum(u.id.startswith("sr3d-between-") for u in utterances) == 38
    toaster = [u for u in utterances if "toaster" in u.text and u.id.startswith("scanrefer")]
    assert toaster and toaster[0].targets == (53,)
    assert all(u.type == "spatial" and len(u.targets) == 1 for u in utterances)


def test_cameras_look_into_the_room(src: Path) -> None:
    source = load_scannet(src)
    cams = walk_cameras(source, 12, 64, 48) + real_cameras(source, 64, 48)
    lo, hi = source.xyz.min(axis=0), source.xyz.max(axis=0)
    for cam in cams:
        assert np.all(cam.center > lo) and np.all(cam.center < hi), cam.name
        proj = cam.project(source.xyz)
        u, v = proj.pixels[:, 0], proj.pixels[:, 1]
        inside = (proj.depth > 0.1) & (u >= 0) & (u < 64) & (v >= 0) & (v < 48)
        assert inside.sum() > 2000, cam.name  # many vertices in view
    walk = [c for c in cams if c.name.startswith("walk_")]
    floor = np.percentile(source.xyz[:, 2], 1)
    assert all(c.center[2] == pytest.approx(floor + 1.5) for c in walk)
    assert len({tuple(np.round(c.center, 3)) for c in walk}) == 12


def test_prepared_counts_and_labels(prepared: Path, raw_labels: np.ndarray, src: Path) -> None:
    ply = read_gaussian_ply(prepared / "point_cloud.ply")
    assert ply.scene.n == N_VERTICES
    np.testing.assert_array_equal(ply.extra["gt_instance"], raw_labels - 1)
    np.testing.assert_array_equal(np.load(prepared / "gt" / "gt_labels.npy"), raw_labels - 1)
    objects = json.loads((prepared / "objects.json").read_text())
    assert objects["scene_id"] == "scene0000_00" and len(objects["objects"]) == N_OBJECTS
    assert [o["id"] for o in objects["objects"]] == list(range(N_OBJECTS))
    # each object's colour: the mean of its vertices' colours, as a build measures it
    source = load_scannet(src)
    for o in objects["objects"]:
        want = source.rgb[source.instance == o["id"]].mean(axis=0) * 255.0
        np.testing.assert_allclose(o["rgb"], want, atol=0.05)
    queries = json.loads((prepared / "queries.json").read_text())["queries"]
    assert len(queries) == 86
    assert all(0 <= t < N_OBJECTS for q in queries for t in q["targets"])
    info = json.loads((prepared / "gt" / "scene.json").read_text())
    assert info["counts"]["gaussians"] == N_VERTICES and info["counts"]["objects"] == N_OBJECTS
    assert info["views"] == ["walk_000", "walk_001", "real_00000", "real_00011", "real_00102"]


def test_prepared_masks_match_the_id_render(prepared: Path, src: Path) -> None:
    source = load_scannet(src)
    scene = gaussians_from_vertices(source.xyz, source.rgb, ScanNetConfig())
    labels = source.instance
    table = {o.id: o.label for o in source.objects}
    cams = walk_cameras(source, 2, 320, 240) + real_cameras(source, 320, 240)
    for cam in cams:
        gt = read_masks(prepared / "gt" / "masks" / f"{cam.name}.npz", image_size=(320, 240))
        np.testing.assert_array_equal(id_map_from_masks(gt), render_ids(scene, cam, labels))
        assert gt.labels == tuple(table[int(i)] for i in gt.ids)  # type: ignore[union-attr]
        assert gt.n >= 3, cam.name
        noisy = read_masks(prepared / "masks" / f"{cam.name}.npz")
        assert set(noisy.labels or ()) <= set(table.values()) | {"object"}
    # the written PLY and COLMAP cameras give the same id render
    ply = read_gaussian_ply(prepared / "point_cloud.ply")
    read = read_colmap_model(prepared / "sparse" / "0").cameras
    assert [c.name for c in read] == [f"{c.name}.png" for c in cams]
    gt = read_masks(prepared / "gt" / "masks" / "real_00011.npz")
    ids = render_ids(ply.scene, read[-2], np.asarray(ply.extra["gt_instance"], dtype=np.int64))
    assert np.mean(id_map_from_masks(gt) == ids) > 0.999


def test_real_pose_renders_resemble_the_photos(prepared: Path) -> None:
    checks = json.loads((prepared / "gt" / "scene.json").read_text())["photo_check"]
    assert [c["view"] for c in checks] == ["real_00000", "real_00011", "real_00102"]
    for c in checks:
        # SOURCE.md: ~31 against ~70 (shuffled colours) for a z-buffered point projection
        assert c["coverage"] > 0.9
        assert c["mae"] < 40 and c["mae"] < 0.6 * c["mae_shuffled"], c
    # the written photo and render agree as the check says
    from PIL import Image

    render = np.asarray(Image.open(prepared / "images" / "real_00102.png"), dtype=np.float64)
    photo = np.asarray(Image.open(prepared / "gt" / "photos" / "real_00102.png"), dtype=np.float64)
    assert np.abs(render - photo).mean() == pytest.approx(checks[2]["mae"], abs=3.0)


def test_prepare_is_deterministic(prepared: Path, src: Path, tmp_path: Path) -> None:
    prepare_scannet(src, tmp_path / "again", n_walk_views=2)
    for path in sorted(prepared.rglob("*")):
        if path.is_file():
            rel = path.relative_to(prepared)
            assert path.read_bytes() == (tmp_path / "again" / rel).read_bytes(), rel


def test_malformed_source_is_refused(src: Path, tmp_path: Path) -> None:
    import shutil

    copy = tmp_path / "src"
    shutil.copytree(src / "language_gt", copy / "language_gt")
    shutil.copytree(src / "mmdet3d_posed_images", copy / "mmdet3d_posed_images")
    (copy / "mmdet3d_votenet_format").mkdir()
    np.save(copy / "mmdet3d_votenet_format" / "scene0000_00_vert_all.npy", np.zeros((4, 6)))
    np.save(copy / "mmdet3d_votenet_format" / "scene0000_00_ins_label_all.npy", np.zeros(5))
    with pytest.raises(ScanNetFormatError, match=r"ins_label_all\.npy: shape"):
        load_scannet(copy)
    np.save(copy / "mmdet3d_votenet_format" / "scene0000_00_ins_label_all.npy", np.full(4, 99))
    with pytest.raises(ScanNetFormatError, match="67 objects"):
        load_scannet(copy)


@pytest.mark.slow
def test_full_prepare(src: Path, tmp_path: Path) -> None:
    summary = prepare_scannet(src, tmp_path / "full")
    assert (summary.n_gaussians, summary.n_entities, summary.n_views) == (N_VERTICES, 67, 63)
    for stem in json.loads((tmp_path / "full" / "gt" / "scene.json").read_text())["views"]:
        gt = read_masks(tmp_path / "full" / "gt" / "masks" / f"{stem}.npz")
        assert gt.n >= 2, stem  # every walk-through view sees annotated objects
