"""The viewer's Gaussian payload: layout, activation, subsampling, scenes without Gaussians,
and the ``/api/scenes/{id}/splats`` route on a real server."""

from __future__ import annotations

import hashlib
import json
import os
import struct
import urllib.error
import urllib.request
from pathlib import Path

import numpy as np
import pytest

from causalsplat import open_store
from causalsplat.io import GaussianScene, write_ply
from causalsplat.serve import App, Server
from causalsplat.serve.splats import (
    BYTES_PER_SPLAT,
    HIGHLIGHT_COLOR,
    SplatCache,
    SplatRequestError,
    decode_payload,
    entity_palette,
    parse_max_splats,
    select_splats,
)
from graph_store import Entity, SceneGraph, SceneMeta
from tests.causalsplat.test_objects import KITCHEN

pytest.importorskip("plyfile", reason="reading PLY needs the build extra")

N = 500


def _gaussians(seed: int = 0) -> GaussianScene:
    rng = np.random.default_rng(seed)
    return GaussianScene(
        means=rng.uniform(-1, 1, (N, 3)),
        quats=rng.normal(size=(N, 4)),
        log_scales=rng.uniform(-4, -1, (N, 3)),
        opacity_logits=rng.normal(size=N),
        sh=rng.normal(size=(N, 1, 3)),
    )


def _graph(folder: Path, ply: Path, *, scene_id: str = "s") -> SceneGraph:
    digest = hashlib.sha256(ply.read_bytes()).hexdigest()
    entities = [
        Entity(i, cat, (0.0, 0.0, 0.0), (-1.0, -1.0, -1.0), (1.0, 1.0, 1.0))
        for i, cat in ((0, "table"), (1, "cup"), (7, "sink"))
    ]
    meta = SceneMeta(
        scene_id=scene_id, source="build",
        provenance=(("point_cloud.ply", digest), ("source_dir", str(folder))),
    )  # fmt: skip
    return SceneGraph(meta=meta, entities=tuple(entities))


@pytest.fixture
def built(tmp_path: Path) -> tuple[SceneGraph, GaussianScene, np.ndarray, Path]:
    folder = tmp_path / "scene"
    folder.mkdir()
    scene = _gaussians()
    write_ply(folder / "point_cloud.ply", scene)
    labels = np.random.default_rng(1).choice([-1, 0, 1, 7], size=N).astype(np.int32)
    return _graph(folder, folder / "point_cloud.ply"), scene, labels, folder


def test_payload_holds_the_activated_gaussians_in_file_order(built) -> None:
    graph, scene, labels, _ = built
    data = SplatCache().payload(graph, labels, max_splats=10_000)
    header, arrays = decode_payload(data)
    assert header["count"] == header["total"] == N
    assert header["sampling"] == "all" and header["reason"] is None
    size = struct.unpack_from("<I", data, 8)[0]
    assert size % 4 == 0 and len(data) == 12 + size + N * BYTES_PER_SPLAT
    for spec in header["arrays"]:
        assert spec["offset"] % 4 == 0
    np.testing.assert_array_equal(arrays["position"], scene.means)
    np.testing.assert_allclose(arrays["scale"], scene.scales, rtol=1e-6)
    q = arrays["rotation"].astype(np.float64) / 127.0
    np.testing.assert_allclose(q, scene.rotations, atol=0.5 / 127 + 1e-9)
    np.testing.assert_allclose(arrays["color"][:, :3] / 255.0, scene.colors, atol=0.5 / 255 + 1e-6)
    np.testing.assert_allclose(
        arrays["color"][:, 3] / 255.0, scene.opacities, atol=0.5 / 255 + 1e-6
    )
    np.testing.assert_array_equal(arrays["entity"], labels)
    assert header["palette"] == {str(k): v for k, v in entity_palette([0, 1, 7]).items()}
    assert header["highlight"] == HIGHLIGHT_COLOR


def test_subsampling_keeps_the_widest_most_opaque_and_is_deterministic(built) -> None:
    graph, scene, labels, _ = built
    first = SplatCache().payload(graph, labels, max_splats=100)
    again = SplatCache().payload(graph, labels, max_splats=100)
    assert first == again
    header, arrays = decode_payload(first)
    assert (header["count"], header["total"], header["sampling"]) == (100, N, "largest")
    two = np.sort(scene.scales, axis=1)[:, 1:]
    weight = scene.opacities * two[:, 0] * two[:, 1]
    kept = np.sort(np.argsort(-weight, kind="stable")[:100])
    np.testing.assert_array_equal(arrays["position"], scene.means[kept])
    np.testing.assert_array_equal(arrays["entity"], labels[kept])
    assert weight[kept].min() >= np.delete(weight, kept).max()


def test_select_splats_breaks_ties_by_file_order() -> None:
    opacity = np.full(6, 0.5)
    assert select_splats(opacity, np.ones((6, 3)), 3).tolist() == [0, 1, 2]
    assert select_splats(opacity, np.ones((6, 3)), 10).tolist() == list(range(6))


def test_a_scene_without_labels_marks_every_gaussian_unassigned(built) -> None:
    graph, *_ = built
    _, arrays = decode_payload(SplatCache().payload(graph, None, max_splats=10_000))
    assert (arrays["entity"] == -1).all()


def test_scenes_without_gaussians_get_an_empty_payload_that_says_why(built, tmp_path) -> None:
    graph, _, labels, folder = built
    objects = tmp_path / "kitchen.json"
    objects.write_text(json.dumps(KITCHEN))
    with open_store(f"sqlite:///{tmp_path / 'k.db'}") as store:
        kitchen = store.ingest_objects(objects).graph
    header, arrays = decode_payload(SplatCache().payload(kitchen, None, max_splats=10))
    assert header["count"] == 0 and arrays["position"].shape == (0, 3)
    assert "not built from a scene folder" in header["reason"]
    assert set(header["palette"]) == {str(e.id) for e in kitchen.entities}

    cache = SplatCache()
    assert decode_payload(cache.payload(graph, labels, max_splats=10))[0]["count"] == 10
    ply = folder / "point_cloud.ply"
    write_ply(ply, _gaussians(seed=5))
    stat = ply.stat()
    os.utime(ply, ns=(stat.st_atime_ns, stat.st_mtime_ns + 10**9))
    header, _ = decode_payload(cache.payload(graph, labels, max_splats=10))
    assert header["count"] == 0 and "changed since scene 's' was built" in header["reason"]

    ply.unlink()
    header, _ = decode_payload(cache.payload(graph, labels, max_splats=10))
    assert header["count"] == 0 and "no 3DGS PLY" in header["reason"]


def test_labels_of_another_length_are_refused(built) -> None:
    graph, *_ = built
    header, _ = decode_payload(
        SplatCache().payload(graph, np.zeros(N + 1, np.int32), max_splats=10)
    )
    assert header["count"] == 0 and f"{N + 1} stored labels for a PLY of {N}" in header["reason"]


@pytest.mark.parametrize("bad", ["0", "-3", "abc", "1e3", "", "99999999"])
def test_max_must_be_a_positive_integer(bad: str) -> None:
    with pytest.raises(SplatRequestError, match="max must be an integer from 1 to"):
        parse_max_splats(bad)


def test_palette_is_stable_distinct_and_far_from_the_highlight() -> None:
    palette = entity_palette(range(200))
    assert palette == entity_palette(range(200))
    assert len(set(palette.values())) == 200
    hi = np.array([int(HIGHLIGHT_COLOR[i : i + 2], 16) for i in (1, 3, 5)])
    for color in palette.values():
        rgb = np.array([int(color[i : i + 2], 16) for i in (1, 3, 5)])
        assert np.abs(rgb - hi).max() > 60, color


def _get(url: str) -> tuple[int, str, bytes]:
    try:
        with urllib.request.urlopen(url, timeout=60) as r:
            return r.status, r.headers["Content-Type"], r.read()
    except urllib.error.HTTPError as exc:
        return exc.code, exc.headers["Content-Type"], exc.read()


def test_the_route_serves_the_payload(built, tmp_path: Path) -> None:
    graph, _, labels, _ = built
    url = f"sqlite:///{tmp_path / 'store.db'}"
    with open_store(url) as store:
        store.save_scene(graph, gaussian_labels=labels)
        server = Server(App(store), "127.0.0.1", 0).start()
        try:
            base = server.url.rstrip("/")
            status, kind, body = _get(f"{base}/api/scenes/s/splats?max=50")
            assert (status, kind) == (200, "application/octet-stream")
            header, arrays = decode_payload(body)
            assert arrays["position"].shape == (50, 3)
            assert header["count"] == 50 and header["scene_id"] == "s"
            status, kind, body = _get(f"{base}/api/scenes/s/splats?max=nope")
            assert status == 400 and "max must be an integer" in json.loads(body)["error"]
            status, _, body = _get(f"{base}/api/scenes/missing/splats")
            assert status == 404 and "missing" in json.loads(body)["error"]
        finally:
            server.shutdown()
