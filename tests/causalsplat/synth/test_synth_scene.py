"""A generated tiny scene, in memory and as a scene folder (DESIGN §9 layout)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from causalsplat.io import read_colmap_model, read_gaussian_ply
from causalsplat.masks import id_map_from_masks, read_masks
from causalsplat.render.functional import render_ids
from causalsplat.synth import SynthConfig, SynthScene, generate_scene, write_synth_scene
from causalsplat.synth.config import InvalidSynthConfigError
from causalsplat.synth.folder import SceneFolderError
from causalsplat.synth.vocab import Kind


@pytest.fixture(scope="module")
def tiny() -> SynthScene:
    return generate_scene(SynthConfig.preset("tiny", seed=0))


@pytest.fixture(scope="module")
def tiny_dir(tiny: SynthScene, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("synth") / "tiny0"
    write_synth_scene(tiny, out)
    return out


def test_counts(tiny: SynthScene) -> None:
    cfg = tiny.config
    assert abs(tiny.gaussians.n - cfg.n_gaussians) <= 0.05 * cfg.n_gaussians
    assert tiny.labels.shape == (tiny.gaussians.n,) and tiny.labels.dtype == np.int32
    assert set(np.unique(tiny.labels)) == {o.id for o in tiny.layout.objects}
    assert len(tiny.cameras) == 12 and tiny.images.shape == (12, 96, 128, 3)
    assert tiny.images.dtype == np.uint8
    for obj in tiny.layout.objects:  # every entity has enough Gaussians, on its own box
        pts = tiny.gaussians.means[tiny.labels == obj.id]
        assert pts.shape[0] >= cfg.min_gaussians_per_object * 0.8
        assert np.all(pts >= obj.lo - 1e-5) and np.all(pts <= obj.hi + 1e-5)


def test_gaussians_are_discs_flat_along_their_face_normal(tiny: SynthScene) -> None:
    g = tiny.gaussians
    assert np.allclose(g.rotation_matrices, np.eye(3), atol=1e-6)  # axis-aligned discs
    scales = np.sort(g.scales.astype(np.float64), axis=1)
    thin = g.scales.argmin(axis=1)
    rows = np.arange(g.n)
    coord = g.means[rows, thin]
    for obj in tiny.layout.objects:  # the thin axis is the normal of the face it sits on
        idx = np.flatnonzero(tiny.labels == obj.id)
        lo, hi = np.asarray(obj.lo)[thin[idx]], np.asarray(obj.hi)[thin[idx]]
        on_face = np.isclose(coord[idx], lo, atol=1e-5) | np.isclose(coord[idx], hi, atol=1e-5)
        assert on_face.all(), obj.category
    # sigmas vary by +-10 % per axis: normal / in-plane lies in normal_scale * [0.9/1.1, 1.1/0.9]
    ratio = scales[:, 0] / scales[:, 1:].mean(axis=1)
    c = tiny.config.normal_scale
    assert ratio.min() >= c * 0.9 / 1.1 - 1e-6 and ratio.max() <= c * 1.1 / 0.9 + 1e-6
    with pytest.raises(InvalidSynthConfigError, match="normal_scale"):
        SynthConfig.preset("tiny", normal_scale=0.0)


def test_gt_masks_are_exactly_the_id_render(tiny: SynthScene) -> None:
    structure = set(tiny.layout.ids_of_kind(Kind.STRUCTURE))
    for cam, gt in zip(tiny.cameras, tiny.gt_masks, strict=True):
        ids = render_ids(tiny.gaussians, cam, tiny.labels)
        np.testing.assert_array_equal(id_map_from_masks(gt), ids)
        assert gt.labels == tuple(tiny.layout.get(int(i)).category for i in gt.ids)  # type: ignore[union-attr]
        assert set(gt.ids.tolist()) - structure, f"{cam.name} sees only floor and walls"  # type: ignore[union-attr]


def test_noise_strength_zero_writes_the_gt_masks() -> None:
    exact = generate_scene(SynthConfig.preset("tiny", seed=1, noise_strength=0.0))
    for noisy, gt in zip(exact.masks, exact.gt_masks, strict=True):
        assert noisy.equals(gt)
    noisy = generate_scene(SynthConfig.preset("tiny", seed=1))
    assert any(not n.equals(g) for n, g in zip(noisy.masks, noisy.gt_masks, strict=True))
    for a, b in zip(exact.gt_masks, noisy.gt_masks, strict=True):  # the noise leaves GT alone
        assert a.equals(b)


def test_folder_layout(tiny: SynthScene, tiny_dir: Path) -> None:
    names = [c.name for c in tiny.cameras]
    for sub in ("images", "masks", "gt/masks"):
        ext = ".png" if sub == "images" else ".npz"
        assert sorted(p.name for p in (tiny_dir / sub).iterdir()) == sorted(n + ext for n in names)
    for path in ("point_cloud.ply", "sparse/0/cameras.txt", "sparse/0/images.txt"):
        assert (tiny_dir / path).is_file()
    for path in ("gt/gt_labels.npy", "gt/scene.json", "objects.json", "queries.json"):
        assert (tiny_dir / path).is_file()
    assert not [p for p in tiny_dir.parent.iterdir() if p.name.startswith(".")]


def test_ply_labels_and_cameras_round_trip(tiny: SynthScene, tiny_dir: Path) -> None:
    ply = read_gaussian_ply(tiny_dir / "point_cloud.ply")
    np.testing.assert_array_equal(ply.scene.means, tiny.gaussians.means)
    np.testing.assert_array_equal(ply.extra["gt_instance"], tiny.labels)
    assert "entity_id" not in ply.extra  # the generator's truth is not named as an entity
    assert any("ground-truth instance" in c for c in ply.layout.comments)
    np.testing.assert_array_equal(np.load(tiny_dir / "gt" / "gt_labels.npy"), tiny.labels)
    model = read_colmap_model(tiny_dir / "sparse" / "0")
    assert [c.name for c in model.cameras] == [f"{c.name}.png" for c in tiny.cameras]
    for read, made in zip(model.cameras, tiny.cameras, strict=True):
        np.testing.assert_allclose(read.T_cam_world, made.T_cam_world, atol=1e-9)
        assert (read.fx, read.cx, read.width) == pytest.approx((made.fx, made.cx, made.width))
        ids = render_ids(ply.scene, read, ply.extra["gt_instance"])
        gt = read_masks(tiny_dir / "gt" / "masks" / f"{made.name}.npz")
        assert np.mean(id_map_from_masks(gt) == ids) > 0.999


def test_written_masks_match_memory(tiny: SynthScene, tiny_dir: Path) -> None:
    for cam, noisy, gt in zip(tiny.cameras, tiny.masks, tiny.gt_masks, strict=True):
        back = read_masks(tiny_dir / "masks" / f"{cam.name}.npz", image_size=(128, 96))
        assert back.equals(noisy)
        assert read_masks(tiny_dir / "gt" / "masks" / f"{cam.name}.npz").equals(gt)
        categories = {o.category for o in tiny.layout.objects} | {"object"}
        assert set(back.labels or ()) <= categories


def test_objects_and_queries_documents(tiny: SynthScene, tiny_dir: Path) -> None:
    objects = json.loads((tiny_dir / "objects.json").read_text())
    assert (objects["scene_id"], objects["units"], objects["up"]) == ("synth-tiny-0", "m", "z")
    assert [o["id"] for o in objects["objects"]] == [o.id for o in tiny.layout.objects]
    for row, obj in zip(objects["objects"], tiny.layout.objects, strict=True):
        assert row["label"] == obj.category
        np.testing.assert_allclose(row["center"], obj.center, atol=1e-6)
        np.testing.assert_allclose(row["size"], obj.size, atol=1e-6)
        pts = np.asarray(row["points"])
        own = int(np.sum(tiny.labels == obj.id))
        assert pts.shape == (min(tiny.config.points_per_object, own), 3)
        assert np.all(pts >= obj.lo - 1e-4) and np.all(pts <= obj.hi + 1e-4)
        assert row["attributes"]["color"] == obj.color
        assert row["attributes"]["affordance"] == list(obj.affordances)
    queries = json.loads((tiny_dir / "queries.json").read_text())
    assert queries["scene_id"] == "synth-tiny-0"
    assert [q["id"] for q in queries["queries"]] == [q.id for q in tiny.queries]
    for row in queries["queries"]:
        assert set(row) == {"id", "text", "type", "targets"}
        assert row["targets"] and all(isinstance(t, int) for t in row["targets"])
    info = json.loads((tiny_dir / "gt" / "scene.json").read_text())
    assert info["config"]["seed"] == 0 and info["counts"]["gaussians"] == tiny.gaussians.n
    assert [e["supporters"] for e in info["entities"]] == [
        list(o.supporters) for o in tiny.layout.objects
    ]


def _tree(root: Path) -> dict[str, bytes]:
    return {
        str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()
    }


def test_same_seed_same_bytes_other_seed_other_bytes(tiny_dir: Path, tmp_path: Path) -> None:
    again = generate_scene(SynthConfig.preset("tiny", seed=0))
    write_synth_scene(again, tmp_path / "again")
    first, second = _tree(tiny_dir), _tree(tmp_path / "again")
    assert first.keys() == second.keys()
    for name in first:
        assert first[name] == second[name], name
    write_synth_scene(generate_scene(SynthConfig.preset("tiny", seed=1)), tmp_path / "other")
    other = _tree(tmp_path / "other")
    for name in ("point_cloud.ply", "images/view_000.png", "queries.json", "objects.json"):
        assert other[name] != first[name], name


def test_output_folder_rules(tiny: SynthScene, tmp_path: Path) -> None:
    busy = tmp_path / "busy"
    busy.mkdir()
    (busy / "notes.txt").write_text("keep me")
    with pytest.raises(SceneFolderError, match="not empty"):
        write_synth_scene(tiny, busy)
    with pytest.raises(SceneFolderError, match="not a scene folder"):
        write_synth_scene(tiny, busy, overwrite=True)
    assert (busy / "notes.txt").read_text() == "keep me"
    (tmp_path / "file").write_text("x")
    with pytest.raises(SceneFolderError, match="not a folder"):
        write_synth_scene(tiny, tmp_path / "file" / "scene")
    empty = tmp_path / "empty"
    empty.mkdir()
    write_synth_scene(tiny, empty)
    write_synth_scene(tiny, empty, overwrite=True)  # replaces its own earlier output
    assert (empty / "gt" / "scene.json").is_file()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["busy", "empty", "file"]


@pytest.mark.slow
@pytest.mark.parametrize("size", ["small", "medium"])
def test_larger_presets(size: str) -> None:
    scene = generate_scene(SynthConfig.preset(size, seed=0))
    cfg = scene.config
    assert abs(scene.gaussians.n - cfg.n_gaussians) <= 0.05 * cfg.n_gaussians
    assert scene.images.shape == (cfg.n_views, cfg.height, cfg.width, 3)
    structure = set(scene.layout.ids_of_kind(Kind.STRUCTURE))
    for cam, gt in zip(scene.cameras, scene.gt_masks, strict=True):
        ids = render_ids(scene.gaussians, cam, scene.labels)
        np.testing.assert_array_equal(id_map_from_masks(gt), ids)
        assert set(gt.ids.tolist()) - structure  # type: ignore[union-attr]
    assert {q.type for q in scene.queries} >= {
        "spatial",
        "commonsense",
        "affordance",
        "counterfactual",
    }
