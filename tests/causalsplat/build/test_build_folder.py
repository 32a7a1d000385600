"""Reading a scene folder (DESIGN §9 layout): PLY and camera variants, masks, GT, errors, hashes."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from causalsplat.build import folder as folder_module
from causalsplat.build.folder import (
    SceneFolder,
    SceneFolderFormatError,
    read_scene_folder,
    view_stem,
)
from causalsplat.errors import InputFormatError
from causalsplat.io import (
    ColmapFormatError,
    ColmapModel,
    ColmapPoints,
    PlyFormatError,
    TransformsFormatError,
    read_colmap_model,
    write_colmap_model,
    write_transforms_json,
)
from causalsplat.masks import MaskSet, read_masks, write_masks
from causalsplat.synth import synth_scene

STEMS = tuple(f"view_{k:03d}" for k in range(12))  # the tiny preset: 12 views of 128x96


@pytest.fixture(scope="session")
def tiny_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The tiny synthetic scene folder, written once; never modified by the tests."""
    out = tmp_path_factory.mktemp("build_folder") / "tiny0"
    synth_scene("tiny", 0, out)
    return out


@pytest.fixture
def scene(tiny_dir: Path, tmp_path: Path) -> Path:
    """A private copy of the tiny folder that a test may change."""
    return Path(shutil.copytree(tiny_dir, tmp_path / "scene"))


def _write_transforms(scene: Path, names: list[str] | None = None) -> None:
    cams = read_colmap_model(scene / "sparse" / "0").cameras
    if names is not None:
        cams = tuple(
            type(c)(n, c.width, c.height, c.fx, c.fy, c.cx, c.cy, c.T_cam_world)
            for c, n in zip(cams, names, strict=True)
        )
    write_transforms_json(scene / "transforms.json", cams)


# --- reading ------------------------------------------------------------------------------


def test_tiny_folder_reads(tiny_dir: Path) -> None:
    sf = read_scene_folder(tiny_dir)
    assert isinstance(sf, SceneFolder)
    assert sf.root == tiny_dir.absolute()
    assert sf.ply_path == tiny_dir / "point_cloud.ply"
    assert sf.cameras_path == tiny_dir / "sparse" / "0"
    assert len(sf.cameras) == len(sf.masks) == 12
    assert tuple(m.view for m in sf.masks) == STEMS
    assert tuple(view_stem(c.name) for c in sf.cameras) == STEMS
    for cam, ms in zip(sf.cameras, sf.masks, strict=True):
        assert ms.masks.shape[1:] == (cam.height, cam.width)
        assert ms.masks.dtype == np.bool_
    assert sf.gt_labels is not None and sf.gt_labels.dtype == np.int32
    assert sf.gt_labels.shape == (sf.gaussians.n,) and sf.gaussians.n > 0
    assert sf.objects_path == tiny_dir / "objects.json"
    assert sf.queries_path == tiny_dir / "queries.json"
    assert sf.skipped_views == ()


def test_read_does_not_hash(tiny_dir: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    def boom(path: Path) -> str:
        raise AssertionError(f"hashed {path} during read")

    monkeypatch.setattr(folder_module, "_sha256", boom)
    read_scene_folder(tiny_dir)


def test_optional_parts_absent(scene: Path) -> None:
    shutil.rmtree(scene / "gt")
    shutil.rmtree(scene / "images")
    (scene / "objects.json").unlink()
    (scene / "queries.json").unlink()
    sf = read_scene_folder(str(scene))
    assert sf.gt_labels is None and sf.objects_path is None and sf.queries_path is None
    assert len(sf.cameras) == 12
    assert "gt/gt_labels.npy" not in sf.input_hashes()


@pytest.mark.parametrize(
    ("name", "stem"),
    [
        ("images/frame_001.png", "frame_001"),
        ("frame_001.png", "frame_001"),
        ("./images/frame_001", "frame_001"),
        ("a\\b\\frame_001.jpg", "frame_001"),
        ("frame.001.JPG", "frame.001"),
    ],
)
def test_view_stem(name: str, stem: str) -> None:
    assert view_stem(name) == stem


def test_inria_layout_takes_largest_iteration(scene: Path) -> None:
    ply = scene / "point_cloud.ply"
    for it in (7000, 30000):
        (scene / "point_cloud" / f"iteration_{it}").mkdir(parents=True)
        shutil.copyfile(ply, scene / "point_cloud" / f"iteration_{it}" / "point_cloud.ply")
    (scene / "point_cloud" / "iteration_99999").mkdir()  # no PLY inside: not a candidate
    (scene / "point_cloud" / "iteration_x").mkdir()
    # a broken PLY at a smaller iteration is never read
    (scene / "point_cloud" / "iteration_7000" / "point_cloud.ply").write_bytes(b"junk")
    ply.unlink()
    sf = read_scene_folder(scene)
    assert sf.ply_path == scene / "point_cloud" / "iteration_30000" / "point_cloud.ply"
    assert sf.gt_labels is not None and sf.gaussians.n == sf.gt_labels.shape[0]
    assert "point_cloud/iteration_30000/point_cloud.ply" in sf.input_hashes()


def test_inria_single_iteration_and_top_level_wins(scene: Path) -> None:
    sub = scene / "point_cloud" / "iteration_7000"
    sub.mkdir(parents=True)
    (sub / "point_cloud.ply").write_bytes(b"not a ply")
    assert read_scene_folder(scene).ply_path == scene / "point_cloud.ply"
    (scene / "point_cloud.ply").rename(sub / "point_cloud.ply")
    assert read_scene_folder(scene).ply_path == sub / "point_cloud.ply"


def test_transforms_json_fallback(scene: Path, tiny_dir: Path) -> None:
    _write_transforms(scene, [f"images/{s}.png" for s in STEMS])
    shutil.rmtree(scene / "sparse")
    sf = read_scene_folder(scene)
    ref = read_scene_folder(tiny_dir)
    assert sf.cameras_path == scene / "transforms.json"
    assert tuple(c.name for c in sf.cameras) == tuple(f"images/{s}.png" for s in STEMS)
    assert tuple(m.view for m in sf.masks) == STEMS
    for a, b in zip(sf.cameras, ref.cameras, strict=True):
        assert (a.width, a.height) == (b.width, b.height)
        np.testing.assert_allclose(a.T_cam_world, b.T_cam_world, atol=1e-9)
    assert "transforms.json" in sf.input_hashes()


def test_sparse_wins_over_transforms_json(scene: Path) -> None:
    (scene / "transforms.json").write_text("{ not json", encoding="utf-8")
    sf = read_scene_folder(scene)
    assert sf.cameras_path == scene / "sparse" / "0"
    assert "transforms.json" not in sf.input_hashes()


def test_binary_colmap_model(scene: Path, tiny_dir: Path) -> None:
    sparse = scene / "sparse" / "0"
    model = read_colmap_model(sparse)
    shutil.rmtree(sparse)
    write_colmap_model(sparse, model, binary=True)
    sf = read_scene_folder(scene)
    assert tuple(m.view for m in sf.masks) == STEMS
    keys = set(sf.input_hashes())
    assert {"sparse/0/cameras.bin", "sparse/0/images.bin"} <= keys
    assert not any(k.endswith(".txt") for k in keys)


def test_views_without_masks_are_skipped(scene: Path) -> None:
    (scene / "masks" / "view_002.npz").unlink()
    (scene / "masks" / "notes.txt").write_text("not a mask file", encoding="utf-8")
    sf = read_scene_folder(scene)
    assert tuple(m.view for m in sf.masks) == tuple(s for s in STEMS if s != "view_002")
    assert tuple(view_stem(c.name) for c in sf.cameras) == tuple(m.view for m in sf.masks)
    assert sf.skipped_views == ("view_002",)


@pytest.mark.parametrize(
    ("max_views", "kept"),
    [
        (1, (0,)),
        (2, (0, 11)),
        (3, (0, 6, 11)),
        (4, (0, 4, 7, 11)),
        (6, (0, 2, 4, 7, 9, 11)),
        (12, tuple(range(12))),
        (50, tuple(range(12))),
    ],
)
def test_max_views_spacing(tiny_dir: Path, max_views: int, kept: tuple[int, ...]) -> None:
    sf = read_scene_folder(tiny_dir, max_views=max_views)
    assert tuple(m.view for m in sf.masks) == tuple(STEMS[i] for i in kept)
    assert tuple(view_stem(c.name) for c in sf.cameras) == tuple(STEMS[i] for i in kept)
    assert sf.skipped_views == ()
    assert set(sf.input_hashes()) >= {f"masks/{STEMS[i]}.npz" for i in kept}


def test_spaced_indices_are_even_and_distinct() -> None:
    for n in range(1, 40):
        for k in range(1, n + 1):
            idx = folder_module._spaced(n, k)
            assert len(idx) == k and idx == sorted(set(idx)) and idx[0] == 0
            if k > 1:
                assert idx[-1] == n - 1
                gaps = np.diff(idx)
                assert gaps.max() - gaps.min() <= 1


@pytest.mark.parametrize("max_views", [0, -3])
def test_max_views_below_one(tiny_dir: Path, max_views: int) -> None:
    with pytest.raises(SceneFolderFormatError, match="max_views"):
        read_scene_folder(tiny_dir, max_views=max_views)


# --- errors -------------------------------------------------------------------------------


def test_error_is_an_input_format_error() -> None:
    assert issubclass(SceneFolderFormatError, InputFormatError)
    assert issubclass(SceneFolderFormatError, ValueError)


def test_missing_folder(tmp_path: Path) -> None:
    with pytest.raises(SceneFolderFormatError, match=r"nope.*does not exist"):
        read_scene_folder(tmp_path / "nope")


def test_path_is_a_file(tmp_path: Path) -> None:
    (tmp_path / "file").write_text("x", encoding="utf-8")
    with pytest.raises(SceneFolderFormatError, match=r"file.*is not a folder"):
        read_scene_folder(tmp_path / "file")


def test_no_ply(scene: Path) -> None:
    (scene / "point_cloud.ply").unlink()
    (scene / "point_cloud" / "iteration_5").mkdir(parents=True)  # empty: no PLY
    with pytest.raises(SceneFolderFormatError, match=r"no 3DGS PLY") as info:
        read_scene_folder(scene)
    msg = str(info.value)
    assert "point_cloud.ply" in msg and "iteration_<N>/point_cloud.ply" in msg


def test_truncated_ply(scene: Path) -> None:
    ply = scene / "point_cloud.ply"
    data = ply.read_bytes()
    ply.write_bytes(data[: len(data) // 2])
    with pytest.raises(SceneFolderFormatError, match=r"point_cloud\.ply") as info:
        read_scene_folder(scene)
    assert isinstance(info.value.__cause__, PlyFormatError)
    assert str(info.value.__cause__) in str(info.value)


def test_no_cameras(scene: Path) -> None:
    shutil.rmtree(scene / "sparse")
    with pytest.raises(SceneFolderFormatError, match=r"no cameras.*sparse.*transforms\.json"):
        read_scene_folder(scene)


def test_bad_colmap_model(scene: Path) -> None:
    cams = scene / "sparse" / "0" / "cameras.txt"
    cams.write_text("1 PINHOLE 96 72 1.0\n", encoding="utf-8")
    with pytest.raises(SceneFolderFormatError, match=r"cameras\.txt") as info:
        read_scene_folder(scene)
    assert isinstance(info.value.__cause__, ColmapFormatError)
    assert str(info.value.__cause__) in str(info.value)


def test_empty_colmap_model(scene: Path) -> None:
    sparse = scene / "sparse" / "0"
    shutil.rmtree(sparse)
    empty = ColmapModel(cameras=(), image_ids=(), points=ColmapPoints.empty())
    write_colmap_model(sparse, empty)
    with pytest.raises(SceneFolderFormatError, match=r"sparse/0.*no cameras"):
        read_scene_folder(scene)


def test_bad_transforms_json(scene: Path) -> None:
    shutil.rmtree(scene / "sparse")
    (scene / "transforms.json").write_text(json.dumps({"frames": [{}]}), encoding="utf-8")
    with pytest.raises(SceneFolderFormatError, match=r"transforms\.json.*transform_matrix") as info:
        read_scene_folder(scene)
    assert isinstance(info.value.__cause__, TransformsFormatError)


def test_duplicate_stems(scene: Path) -> None:
    _write_transforms(scene, ["a/view_000.png", "b/view_000.jpg", *[f"{s}.png" for s in STEMS[2:]]])
    shutil.rmtree(scene / "sparse")
    (scene / "masks" / "view_001.npz").unlink()
    with pytest.raises(SceneFolderFormatError, match=r"share the image stem 'view_000'"):
        read_scene_folder(scene)


def test_no_masks_folder(scene: Path) -> None:
    shutil.rmtree(scene / "masks")
    with pytest.raises(SceneFolderFormatError, match=r"no masks folder"):
        read_scene_folder(scene)


def test_no_camera_has_masks(scene: Path) -> None:
    for p in (scene / "masks").iterdir():
        p.unlink()
    with pytest.raises(SceneFolderFormatError, match=r"masks: no camera has a mask file"):
        read_scene_folder(scene)


def test_mask_file_without_camera(scene: Path) -> None:
    shutil.copyfile(scene / "masks" / "view_000.npz", scene / "masks" / "stray_view.npz")
    with pytest.raises(SceneFolderFormatError, match=r"stray_view\.npz match no camera"):
        read_scene_folder(scene)


def test_mask_size_mismatch(scene: Path) -> None:
    path = scene / "masks" / "view_003.npz"
    ms = read_masks(path)
    write_masks(path, MaskSet(view=ms.view, masks=ms.masks[:, :-2, :], labels=ms.labels))
    with pytest.raises(SceneFolderFormatError, match=r"view_003\.npz.*128x94.*expected 128x96"):
        read_scene_folder(scene)


def test_corrupt_mask_file(scene: Path) -> None:
    (scene / "masks" / "view_004.npz").write_bytes(b"PK\x03\x04 truncated")
    with pytest.raises(SceneFolderFormatError, match=r"view_004\.npz"):
        read_scene_folder(scene)


def test_corrupt_mask_file_outside_max_views_is_not_read(scene: Path) -> None:
    (scene / "masks" / "view_004.npz").write_bytes(b"garbage")
    assert len(read_scene_folder(scene, max_views=2).masks) == 2


@pytest.mark.parametrize(
    ("labels", "pattern"),
    [
        (lambda n: np.zeros(n + 1, dtype=np.int32), r"shape \(\d+,\); expected \(\d+,\) int"),
        (lambda n: np.zeros((n, 1), dtype=np.int32), r"expected \(\d+,\) int"),
        (lambda n: np.zeros(n, dtype=np.float32), r"dtype float32"),
        (lambda n: np.full(n, -2, dtype=np.int64), r"ids range -2\.\."),
        (lambda n: np.full(n, 2**40, dtype=np.int64), r"non-negative int32"),
    ],
    ids=["too-long", "2d", "float", "below-minus-one", "over-int32"],
)
def test_bad_gt_labels(scene: Path, labels: Callable[[int], np.ndarray], pattern: str) -> None:
    n = read_scene_folder(scene).gaussians.n
    np.save(scene / "gt" / "gt_labels.npy", labels(n))
    with pytest.raises(SceneFolderFormatError, match=rf"gt_labels\.npy.*{pattern}"):
        read_scene_folder(scene)


def test_unreadable_gt_labels(scene: Path) -> None:
    (scene / "gt" / "gt_labels.npy").write_bytes(b"\x93NUMPY garbage")
    with pytest.raises(SceneFolderFormatError, match=r"gt_labels\.npy: not a readable"):
        read_scene_folder(scene)


def test_gt_labels_int64_become_int32(scene: Path) -> None:
    labels = np.load(scene / "gt" / "gt_labels.npy").astype(np.int64)
    np.save(scene / "gt" / "gt_labels.npy", labels)
    sf = read_scene_folder(scene)
    assert sf.gt_labels is not None and sf.gt_labels.dtype == np.int32
    np.testing.assert_array_equal(sf.gt_labels, labels)


# --- hashes -------------------------------------------------------------------------------


def test_input_hashes_stable_and_sensitive(scene: Path) -> None:
    first = read_scene_folder(scene).input_hashes()
    second = read_scene_folder(scene).input_hashes()
    assert first == second
    assert list(first) == sorted(first)
    expected = {"point_cloud.ply", "sparse/0/cameras.txt", "sparse/0/images.txt"}
    expected |= {f"masks/{s}.npz" for s in STEMS} | {"gt/gt_labels.npy"}
    assert set(first) == expected
    assert all(len(v) == 64 and int(v, 16) >= 0 for v in first.values())

    path = scene / "masks" / "view_002.npz"
    ms = read_masks(path)
    flipped = ms.masks.copy()
    flipped[0, 0, 0] = not flipped[0, 0, 0]
    write_masks(path, MaskSet(view=ms.view, masks=flipped, labels=ms.labels, scores=ms.scores))
    third = read_scene_folder(scene).input_hashes()
    changed = {k for k in first if first[k] != third[k]}
    assert changed == {"masks/view_002.npz"}


def test_module_imports_without_torch() -> None:
    script = (
        "import sys, causalsplat.build.folder\n"
        "print(','.join(m for m in ('torch', 'plyfile') if m in sys.modules))"
    )
    proc = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, check=True
    )
    assert proc.stdout.strip() == ""
