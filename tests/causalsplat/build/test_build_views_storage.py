"""Where a build keeps its views: in memory, memory-mapped from disk, or rebuilt per use.

The storage changes speed and memory only: every choice gives the same scene, the spill
folder is gone after the build, and the scene's config hash does not see the choice.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from causalsplat.build import BuildConfig, build_scene
from causalsplat.build.config import BuildConfigError
from causalsplat.build.folder import SceneFolderFormatError
from causalsplat.field import FieldConfig, prepare_views
from causalsplat.field.spill import ArrayCodec, ViewSpill
from graph_store import SceneGraph

_FAST = {"field": FieldConfig(iterations=40)}


def _spill_folders(root: Path) -> list[str]:
    return sorted(p.name for p in root.glob("causalsplat-views-*"))


@pytest.fixture(scope="module")
def reference(tiny_folder: Path) -> tuple[np.ndarray, SceneGraph]:
    result = build_scene(tiny_folder, config=BuildConfig(views="memory", **_FAST), cache_dir=False)
    return result.gaussian_labels, result.graph


@pytest.mark.parametrize(
    "views, budget_mib", [("disk", None), ("recompute", None), ("auto", 0), ("auto", 1)]
)
def test_every_storage_builds_the_same_scene(
    tiny_folder: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    reference: tuple[np.ndarray, SceneGraph],
    views: str,
    budget_mib: int | None,
) -> None:
    monkeypatch.setenv("TMPDIR", str(tmp_path))
    import tempfile

    monkeypatch.setattr(tempfile, "tempdir", None)  # re-read TMPDIR
    config = BuildConfig(views=views, memory_budget_mib=budget_mib, **_FAST)  # type: ignore[arg-type]
    result = build_scene(tiny_folder, config=config, cache_dir=False)
    labels, graph = reference
    np.testing.assert_array_equal(result.gaussian_labels, labels)
    assert result.graph == graph  # config_hash included: speed knobs are left out
    assert _spill_folders(tmp_path) == []


def test_disk_views_are_memory_mapped_and_removed_on_close(
    tiny_folder: Path, tmp_path: Path
) -> None:
    from causalsplat.build.folder import read_scene_folder

    folder = read_scene_folder(tiny_folder, max_views=3)
    field = FieldConfig()
    memory = prepare_views(folder.gaussians, folder.cameras, folder.masks, field)
    disk = prepare_views(
        folder.gaussians, folder.cameras, folder.masks, field, storage="disk", spill_dir=tmp_path
    )
    assert disk.spilled_bytes > 0 and memory.spilled_bytes == 0
    assert len(_spill_folders(tmp_path)) == 1
    for a, b in zip(memory.contributors, disk.contributors, strict=True):
        assert isinstance(b.weights, np.memmap) and not b.weights.flags.writeable
        np.testing.assert_array_equal(a.indptr, b.indptr)
        np.testing.assert_array_equal(a.indices, b.indices)
        np.testing.assert_array_equal(a.weights, b.weights)
    for a, b in zip(memory.masks, disk.masks, strict=True):
        assert (a.weights != b.weights).nnz == 0 and a.mask_index.tolist() == b.mask_index.tolist()
    disk.close()
    assert _spill_folders(tmp_path) == []


def test_a_spill_keeps_views_resident_up_to_its_budget(tmp_path: Path) -> None:
    spill = ViewSpill(ArrayCodec(), budget_bytes=64, folder=tmp_path)
    arrays = [np.arange(k, dtype=np.float64) for k in (4, 4, 1, 8)]  # 32, 32, 8, 64 bytes
    for a in arrays:
        spill.append(a)
    assert (spill.resident_bytes, spill.spilled_bytes, spill.n_spilled) == (64, 72, 2)
    assert [x.tolist() for x in spill] == [a.tolist() for a in arrays]
    assert spill[-1].tolist() == arrays[-1].tolist() and len(spill[1:3]) == 2
    with pytest.raises(IndexError, match="view 4 out of range"):
        spill[4]
    (folder,) = list(tmp_path.iterdir())
    assert len(os.listdir(folder)) == 2
    del spill  # collected: its files go too
    assert not folder.exists()


@pytest.mark.parametrize("huge_pages", [False, True])
def test_huge_page_advice_changes_nothing_but_speed_and_is_restored(
    tiny_folder: Path, reference: tuple[np.ndarray, SceneGraph], huge_pages: bool
) -> None:
    """The build sets numpy's huge-page advice as asked while it runs, and gives back the
    process's own setting afterwards (even when the build fails)."""
    from causalsplat.build import pipeline
    from causalsplat.build.huge_pages import _switch

    setter = _switch()
    if setter is None:
        pytest.skip("this numpy has no huge-page switch")

    seen: list[bool] = []
    real = pipeline._build

    def spy(*args: object) -> object:
        before = setter(True)  # read the setting in force
        setter(before)
        seen.append(before)
        return real(*args)  # type: ignore[arg-type]

    mine = setter(not huge_pages)  # the opposite of the build's
    try:
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(pipeline, "_build", spy)
            config = BuildConfig(views="memory", huge_pages=huge_pages, **_FAST)
            result = build_scene(tiny_folder, config=config, cache_dir=False)
            assert seen == [huge_pages]
            assert setter(not huge_pages) is (not huge_pages)
            with pytest.raises(SceneFolderFormatError, match="does not exist"):
                build_scene(tiny_folder / "missing", config=config, cache_dir=False)
            assert setter(not huge_pages) is (not huge_pages)
    finally:
        setter(mine)
    labels, graph = reference
    np.testing.assert_array_equal(result.gaussian_labels, labels)
    assert result.graph == graph


@pytest.mark.parametrize(
    "key, value, match",
    [
        ("views", "ram", r"views='ram' must be one of 'auto', 'memory', 'disk', 'recompute'"),
        ("memory_budget_mib", -1, r"memory_budget_mib must be an integer in \[0, inf\)"),
        ("memory_budget_mib", 1.5, r"memory_budget_mib must be an integer in \[0, inf\)"),
        ("huge_pages", "yes", r"huge_pages='yes' must be true or false"),
    ],
)
def test_storage_options_are_checked(key: str, value: object, match: str) -> None:
    with pytest.raises(BuildConfigError, match=match):
        BuildConfig.from_json({key: value})


def test_views_past_the_disk_allowance_are_rebuilt_at_each_use(tmp_path: Path) -> None:
    built: list[int] = []

    def rebuild(i: int) -> np.ndarray:
        built.append(i)
        return np.full(4, i, dtype=np.float64)

    spill = ViewSpill(ArrayCodec(), 32, tmp_path, disk_bytes=64, rebuild=rebuild)
    for i in range(5):  # 32 bytes each: one resident, two on disk, two rebuilt
        spill.append(np.full(4, i, dtype=np.float64))
    assert (spill.resident_bytes, spill.spilled_bytes) == (32, 64)
    assert (spill.n_spilled, spill.n_rebuilt) == (2, 2)
    assert [int(x[0]) for x in spill] == [0, 1, 2, 3, 4] and built == [3, 4]
    with pytest.raises(ValueError, match="needs rebuild"):
        ViewSpill(ArrayCodec(), 0, disk_bytes=0)


def test_the_build_report_says_where_the_views_stayed(tiny_folder: Path) -> None:
    config = BuildConfig(views="disk", **_FAST)
    doc = build_scene(tiny_folder, config=config, cache_dir=False).to_json()
    report = doc["views_storage"]
    assert report["storage"] == "disk" and report["spilled_mib"] > 0
    assert (report["resident"], report["on_disk"], report["rebuilt"]) == (0, 12, 0)
