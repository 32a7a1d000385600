"""The PLY export: the source file unchanged with the labels beside it, or one appended
``causalsplat_entity`` property; on the real INRIA sample and on a synthetic PLY that carries
a ground-truth ``entity_id`` column.

The scenes here are made without a build: a folder with the PLY, and a graph whose
provenance records the folder and the PLY's SHA-256, exactly as a build records them.
"""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from causalsplat.export import EMBEDDED_PROPERTY, ExportError, export_labelled_ply
from causalsplat.io import GaussianScene, read_gaussian_ply, write_ply
from graph_store import Entity, SceneGraph, SceneMeta
from tests.conftest import shared_data_path

#: The 62 float properties of an INRIA 3DGS PLY of SH degree 3, in file order.
INRIA_PROPERTIES = [
    "x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2",
    *[f"f_rest_{i}" for i in range(45)],
    "opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3",
]  # fmt: skip


def _scene_folder(tmp_path: Path, ply: Path) -> tuple[Path, SceneGraph, np.ndarray]:
    """A scene folder holding ``ply``, a three-entity graph of it and labels for it."""
    folder = tmp_path / "scene"
    folder.mkdir()
    shutil.copyfile(ply, folder / "point_cloud.ply")
    n = read_gaussian_ply(ply).scene.n
    rng = np.random.default_rng(0)
    labels = rng.integers(-1, 3, size=n).astype(np.int32)
    entities = tuple(
        Entity(k, ("chair", "table", "lamp")[k], (k, 0.0, 0.5), (k - 0.4, -0.4, 0.0),
               (k + 0.4, 0.4, 1.0), external_id=f"e{k}")
        for k in range(3)
    )  # fmt: skip
    digest = hashlib.sha256((folder / "point_cloud.ply").read_bytes()).hexdigest()
    meta = SceneMeta("room", source="build",
                     provenance={"point_cloud.ply": digest, "source_dir": str(folder)})  # fmt: skip
    return folder, SceneGraph(meta, entities, ()), labels


def _header(path: Path) -> bytes:
    data = path.read_bytes()
    return data[: data.index(b"end_header\n") + len(b"end_header\n")]


def _property_lines(header: bytes) -> list[str]:
    return [line for line in header.decode("ascii").splitlines() if line.startswith("property")]


def _synthetic_ply(tmp_path: Path) -> tuple[Path, np.ndarray]:
    """A degree-1 PLY of 500 Gaussians with a ground-truth ``entity_id`` column."""
    rng = np.random.default_rng(1)
    n = 500
    scene = GaussianScene(
        means=rng.normal(size=(n, 3)).astype(np.float32),
        quats=rng.normal(size=(n, 4)).astype(np.float32),
        log_scales=rng.normal(-3, 0.5, size=(n, 3)).astype(np.float32),
        opacity_logits=rng.normal(size=n).astype(np.float32),
        sh=rng.normal(size=(n, 4, 3)).astype(np.float32),
    )
    gt = rng.integers(0, 7, size=n).astype(np.int32)
    path = tmp_path / "synthetic.ply"
    write_ply(path, scene, extra={"entity_id": gt})
    return path, gt


@pytest.mark.shared_data
def test_plain_export_of_the_inria_sample_is_the_source_file(tmp_path: Path) -> None:
    source = shared_data_path("inria_3dgs_ply_sample", "point_cloud_iter7000.ply")
    _, graph, labels = _scene_folder(tmp_path, source)
    out = tmp_path / "out" / "room.ply"
    out.parent.mkdir()
    done = export_labelled_ply(graph, labels, out)
    assert out.read_bytes() == source.read_bytes()
    # the fixed INRIA record: the header lists exactly the 62 float properties
    assert _property_lines(_header(out)) == [f"property float {p}" for p in INRIA_PROPERTIES]
    assert done.labels_npy == tmp_path / "out" / "room.labels.npy"
    assert done.paths == [out, done.labels_npy, done.labels_json]
    stored = np.load(done.labels_npy)
    assert stored.dtype == np.dtype("<i4")
    np.testing.assert_array_equal(stored, labels)
    assert done.labels_json is not None
    meta = json.loads(done.labels_json.read_text(encoding="utf-8"))
    assert meta["scene_id"] == "room" and meta["count"] == 9080 and meta["none"] == -1
    assert meta["ply_sha256"] == hashlib.sha256(source.read_bytes()).hexdigest()
    assert meta["labels"] == "room.labels.npy" and meta["ply"] == "room.ply"
    assert meta["entities"]["1"]["category"] == "table"
    assert meta["entities"]["1"]["gaussians"] == int((labels == 1).sum())
    assert len(meta["entities"]["2"]["display_rgb"]) == 3
    assert sorted(p.name for p in out.parent.iterdir()) == [
        "room.labels.json", "room.labels.npy", "room.ply"]  # fmt: skip


@pytest.mark.shared_data
def test_embedded_export_of_the_inria_sample_appends_one_int(tmp_path: Path) -> None:
    source = shared_data_path("inria_3dgs_ply_sample", "point_cloud_iter7000.ply")
    _, graph, labels = _scene_folder(tmp_path, source)
    out = tmp_path / "embedded.ply"
    done = export_labelled_ply(graph, labels, out, embed=True)
    assert done.paths == [out] and done.labels_npy is None
    head, src_head = _header(out), _header(source)
    assert head == src_head.replace(
        b"end_header\n", f"property int {EMBEDDED_PROPERTY}\nend_header\n".encode()
    )
    records = np.frombuffer(out.read_bytes()[len(head) :], dtype=np.uint8).reshape(9080, 62 * 4 + 4)
    src = np.frombuffer(source.read_bytes()[len(src_head) :], dtype=np.uint8).reshape(9080, 62 * 4)
    np.testing.assert_array_equal(records[:, :-4], src)
    np.testing.assert_array_equal(records[:, -4:].copy().view("<i4").ravel(), labels)


def test_a_ground_truth_entity_id_column_is_kept(tmp_path: Path) -> None:
    ply, gt = _synthetic_ply(tmp_path)
    _, graph, labels = _scene_folder(tmp_path, ply)
    plain = export_labelled_ply(graph, labels, tmp_path / "plain.ply")
    assert plain.ply.read_bytes() == ply.read_bytes()
    np.testing.assert_array_equal(np.load(tmp_path / "plain.labels.npy"), labels)
    embedded = export_labelled_ply(graph, labels, tmp_path / "embedded.ply", embed=True)
    back = read_gaussian_ply(embedded.ply)
    names = [n for n, _ in back.layout.properties]
    assert names == [n for n, _ in read_gaussian_ply(ply).layout.properties] + [EMBEDDED_PROPERTY]
    np.testing.assert_array_equal(back.extra["entity_id"], gt)
    np.testing.assert_array_equal(back.extra[EMBEDDED_PROPERTY], labels)
    assert back.layout.properties[-1] == (EMBEDDED_PROPERTY, "<i4")


def test_per_entity_plys_keep_the_source_layout(tmp_path: Path) -> None:
    ply, gt = _synthetic_ply(tmp_path)
    _, graph, labels = _scene_folder(tmp_path, ply)
    done = export_labelled_ply(graph, labels, tmp_path / "r.ply", per_entity_dir=tmp_path / "e")
    assert [p.name for p in done.per_entity] == ["0_chair.ply", "1_table.ply", "2_lamp.ply"]
    source = read_gaussian_ply(ply)
    for k, path in enumerate(done.per_entity):
        part = read_gaussian_ply(path)
        assert part.layout == source.layout
        np.testing.assert_array_equal(part.extra["entity_id"], gt[labels == k])
        np.testing.assert_array_equal(part.scene.means, source.scene.means[labels == k])


def test_refusals_write_nothing(tmp_path: Path) -> None:
    ply, _ = _synthetic_ply(tmp_path)
    folder, graph, labels = _scene_folder(tmp_path, ply)
    out = tmp_path / "o.ply"
    with pytest.raises(ExportError, match="500 Gaussians"):
        export_labelled_ply(graph, labels[:-1], out)
    with pytest.raises(ExportError, match="stores no per-Gaussian labels"):
        export_labelled_ply(graph, None, out)
    with pytest.raises(ExportError, match="is the scene's source PLY"):
        export_labelled_ply(graph, labels, folder / "point_cloud.ply", embed=True)
    with pytest.raises(ExportError, match="is a folder"):
        export_labelled_ply(graph, labels, tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scene", "synthetic.ply"]
    assert (folder / "point_cloud.ply").read_bytes() == ply.read_bytes()
