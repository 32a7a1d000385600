"""Exports of a built scene: labelled PLY, per-entity PLYs, answer masks, the figure."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from causalsplat import open_store
from causalsplat.build import BuildConfig
from causalsplat.export import ExportError, export_labelled_ply, overlay_mask
from causalsplat.field import FieldConfig
from causalsplat.io import read_gaussian_ply
from tests.causalsplat.test_cli_store import assert_one_line_error, run
from tests.causalsplat.test_objects import KITCHEN


@pytest.fixture(scope="module")
def built_db(tiny_folder: Path, tmp_path_factory: pytest.TempPathFactory) -> tuple[str, Path]:
    work = tmp_path_factory.mktemp("exports")
    folder = work / "scene"
    shutil.copytree(tiny_folder, folder)
    url = f"sqlite:///{work / 'x.db'}"
    with open_store(url) as store:
        store.build(folder, scene_id="t", config=BuildConfig(field=FieldConfig(iterations=30)),
                    cache_dir=False)  # fmt: skip
        kitchen = work / "kitchen.json"
        kitchen.write_text(json.dumps(KITCHEN))
        store.ingest_objects(kitchen)
    return url, folder


def test_ply_and_per_entity_plys(built_db: tuple[str, Path], tmp_path: Path) -> None:
    url, folder = built_db
    out = tmp_path / "labelled.ply"
    args = ["export", "--scene", "t", "--format", "ply", "-o", str(out),
            "--per-entity", str(tmp_path / "ents"), "--json"]  # fmt: skip
    doc = json.loads(run(*args, db=url).stdout)
    with open_store(url) as store:
        labels = store.scene("t").gaussian_labels()
        graph = store.scene("t").graph
    assert labels is not None
    # the PLY is the scene folder's, byte for byte; the labels lie beside it
    assert out.read_bytes() == (folder / "point_cloud.ply").read_bytes()
    assert doc["paths"][:3] == [str(out), str(tmp_path / "labelled.labels.npy"),
                                str(tmp_path / "labelled.labels.json")]  # fmt: skip
    np.testing.assert_array_equal(np.load(tmp_path / "labelled.labels.npy"), labels)
    meta = json.loads((tmp_path / "labelled.labels.json").read_text())
    assert meta["count"] == labels.size and set(meta["entities"]) == {
        str(e.id) for e in graph.entities}  # fmt: skip
    source = read_gaussian_ply(folder / "point_cloud.ply")
    assert len(doc["paths"]) == 3 + len(graph.entities)
    total = sum(read_gaussian_ply(p).scene.n for p in doc["paths"][3:])
    assert total == int((labels >= 0).sum())
    # --embed-labels: the source's properties (its gt_instance too), then causalsplat_entity
    embedded = tmp_path / "embedded.ply"
    text = run("export", "--scene", "t", "--format", "ply", "--embed-labels", "-o",
               str(embedded), db=url).stdout  # fmt: skip
    assert text.strip() == f"wrote {embedded}"
    ply = read_gaussian_ply(embedded)
    np.testing.assert_array_equal(ply.extra["causalsplat_entity"], labels)
    np.testing.assert_array_equal(ply.extra["gt_instance"], source.extra["gt_instance"])
    np.testing.assert_array_equal(ply.scene.means, source.scene.means)


def test_answer_masks_match_the_answers_gaussians(built_db: tuple[str, Path],
                                                  tmp_path: Path) -> None:  # fmt: skip
    url, _ = built_db
    doc = json.loads(run("export", "--scene", "t", "--format", "masks", "--ask",
                         "where can I wash my hands?", "-o", str(tmp_path / "m"), "--json",
                         db=url).stdout)  # fmt: skip
    assert doc["answer"] and len(doc["paths"]) == 12
    images = [np.asarray(Image.open(p)) for p in doc["paths"]]
    assert all(i.shape == (96, 128) and set(np.unique(i)) <= {0, 255} for i in images)
    assert sum(int((i > 0).sum()) for i in images) > 0


def test_answer_overlays(built_db: tuple[str, Path], tmp_path: Path) -> None:
    """--overlay: each view's image (the folder's images/) with the mask drawn over it."""
    url, folder = built_db
    out = tmp_path / "m"
    doc = json.loads(run("export", "--scene", "t", "--format", "masks", "--ask",
                         "where can I wash my hands?", "-o", str(out), "--overlay", "--json",
                         db=url).stdout)  # fmt: skip
    masks = [Path(p) for p in doc["paths"] if Path(p).parent == out]
    overlays = [Path(p) for p in doc["paths"] if Path(p).parent == out / "overlay"]
    assert len(masks) == len(overlays) == 12
    for mask_path in masks:
        mask = np.asarray(Image.open(mask_path)) > 0
        drawn = np.asarray(Image.open(out / "overlay" / mask_path.name))
        [image_path] = (folder / "images").glob(f"{mask_path.stem}.*")
        image = np.asarray(Image.open(image_path).convert("RGB"))
        assert drawn.shape == image.shape
        np.testing.assert_array_equal(drawn, overlay_mask(image, mask))


def test_figure(built_db: tuple[str, Path], tmp_path: Path) -> None:
    url, _ = built_db
    out = tmp_path / "g.png"
    run("export", "--scene", "t", "--format", "png", "-o", str(out), db=url)
    image = Image.open(out)
    assert image.format == "PNG" and image.width == 1200 and image.height > 200


def test_export_errors(built_db: tuple[str, Path], tmp_path: Path) -> None:
    url, _ = built_db
    out = str(tmp_path / "x.ply")
    assert_one_line_error(run("export", "--scene", "kitchen", "--format", "ply", "-o", out,
                              db=url, check=False), "not built from a scene folder")  # fmt: skip
    assert_one_line_error(run("export", "--format", "ply", "-o", out, db=url, check=False),
                          "exactly one --scene")  # fmt: skip
    assert_one_line_error(run("export", "--scene", "t", "--format", "masks", "-o", out,
                              db=url, check=False), "--ask")  # fmt: skip
    assert_one_line_error(run("export", "--scene", "t", "--format", "ply", "--source",
                              str(tmp_path), "-o", out, db=url, check=False), "PLY")  # fmt: skip
    assert not Path(out).exists()


def test_an_edited_ply_is_refused(built_db: tuple[str, Path], tmp_path: Path) -> None:
    url, folder = built_db
    edited = tmp_path / "edited"
    shutil.copytree(folder, edited)
    with (edited / "point_cloud.ply").open("ab") as f:
        f.write(b"\0")
    with open_store(url) as store:
        scene = store.scene("t")
        with pytest.raises(ExportError, match="changed since"):
            export_labelled_ply(scene.graph, scene.gaussian_labels(), tmp_path / "o.ply",
                                source=edited)  # fmt: skip


def test_overlays_render_a_view_without_an_image(
    built_db: tuple[str, Path], tmp_path: Path
) -> None:
    """A scene folder without images/: the overlay is drawn over the view rendered from the
    Gaussians (through the API, one view)."""
    from causalsplat.build.folder import read_cameras
    from causalsplat.render import render_rgb

    url, folder = built_db
    bare = tmp_path / "bare"
    shutil.copytree(folder, bare, ignore=shutil.ignore_patterns("images"))
    with open_store(url) as store:
        scene = store.scene("t")
        answer = scene.ask("where can I wash my hands?")
        paths = scene.export_masks(answer.entity_ids, tmp_path / "m", source=bare,
                                   views=["view_002"], overlay=True)  # fmt: skip
    assert [p.relative_to(tmp_path).as_posix() for p in paths] == [
        "m/view_002.png", "m/overlay/view_002.png"]  # fmt: skip
    [camera] = [c for c in read_cameras(bare)[1] if Path(c.name).stem == "view_002"]
    image = render_rgb(read_gaussian_ply(bare / "point_cloud.ply").scene, camera)
    mask = np.asarray(Image.open(paths[0])) > 0
    np.testing.assert_array_equal(np.asarray(Image.open(paths[1])), overlay_mask(image, mask))
