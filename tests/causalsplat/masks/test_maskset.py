"""MaskSet: validation, the .npz file format, and GT masks from id renders."""

from __future__ import annotations

import tempfile
import zipfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from causalsplat.errors import InputFormatError
from causalsplat.masks import (
    MaskFormatError,
    MaskSet,
    id_map_from_masks,
    masks_from_id_render,
    read_mask_dir,
    read_masks,
    write_masks,
    write_npz,
)


def _example() -> MaskSet:
    masks = np.zeros((3, 6, 8), dtype=bool)
    masks[0, :3, :4] = True
    masks[1, 3:, :] = True
    masks[2, 1:5, 5:] = True
    return MaskSet("view_000", masks, ("cup", "table", "lampe à poser"), np.array([0.9, 1, 0.5]))


def test_maskset_validates_dtype_shape_and_counts() -> None:
    good = _example()
    assert (good.n, good.height, good.width) == (3, 6, 8)
    with pytest.raises(MaskFormatError, match="dtype float64"):
        MaskSet("v", good.masks.astype(np.float64))
    with pytest.raises(MaskFormatError, match=r"shape \(6, 8\)"):
        MaskSet("v", good.masks[0])
    with pytest.raises(MaskFormatError, match="2 labels for 3 masks"):
        MaskSet("v", good.masks, labels=("a", "b"))
    with pytest.raises(MaskFormatError, match="not a string"):
        MaskSet("v", good.masks, labels=("a", "b", 3))  # type: ignore[arg-type]
    with pytest.raises(MaskFormatError, match="scores"):
        MaskSet("v", good.masks, scores=np.ones(2))
    with pytest.raises(MaskFormatError, match="NaN"):
        MaskSet("v", good.masks, scores=np.array([1.0, np.nan, 0.0]))
    with pytest.raises(MaskFormatError, match="ids"):
        MaskSet("v", good.masks, ids=np.array([0.5, 1.0, 2.0]))
    assert issubclass(MaskFormatError, InputFormatError)


def test_maskset_is_a_read_only_copy() -> None:
    masks = np.ones((1, 2, 2), dtype=bool)
    ms = MaskSet("v", masks)
    masks[0, 0, 0] = False
    assert ms.masks.all()
    with pytest.raises(ValueError):
        ms.masks[0, 0, 0] = False


def test_write_read_round_trip_and_bytes_are_deterministic(tmp_path: Path) -> None:
    ms = _example()
    write_masks(tmp_path / "a.npz", ms)
    write_masks(tmp_path / "b.npz", ms)
    assert (tmp_path / "a.npz").read_bytes() == (tmp_path / "b.npz").read_bytes()
    back = read_masks(tmp_path / "a.npz", view="view_000", image_size=(8, 6))
    assert back.equals(ms)
    assert back.scores is not None and back.scores.dtype == np.float32
    # the file is a plain npz numpy can read without pickles
    with np.load(tmp_path / "a.npz", allow_pickle=False) as data:
        assert sorted(data.files) == ["labels", "masks", "scores"]
        assert data["masks"].dtype == np.bool_


@settings(max_examples=30, deadline=None)
@given(
    masks=hnp.arrays(np.bool_, st.tuples(st.integers(0, 4), st.integers(1, 7), st.integers(1, 7))),
    data=st.data(),
)
def test_round_trip_property(masks: np.ndarray, data: st.DataObject) -> None:
    m = masks.shape[0]
    # numpy unicode arrays drop trailing NULs, so labels never contain NUL
    text = st.text(st.characters(exclude_characters="\x00", exclude_categories=["Cs"]), max_size=8)
    labels = data.draw(st.none() | st.lists(text, min_size=m, max_size=m))
    scores = data.draw(st.none() | hnp.arrays(np.float32, m, elements=st.floats(0, 1, width=32)))
    ms = MaskSet("v", masks, None if labels is None else tuple(labels), scores)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "v.npz"
        write_masks(path, ms)
        back = read_masks(path)
    assert back.equals(ms)


def _npz(path: Path, **arrays: np.ndarray) -> Path:
    np.savez(path, **arrays)  # type: ignore[arg-type]
    return path


def test_read_errors_name_the_problem(tmp_path: Path) -> None:
    masks = np.zeros((2, 4, 5), dtype=bool)
    (tmp_path / "text.npz").write_text("not a zip")
    with pytest.raises(MaskFormatError, match=r"not a readable \.npz"):
        read_masks(tmp_path / "text.npz")
    np.save(tmp_path / "single.npy", masks)
    with pytest.raises(MaskFormatError, match=r"single \.npy array"):
        read_masks(tmp_path / "single.npy")
    with pytest.raises(MaskFormatError, match="no 'masks' array"):
        read_masks(_npz(tmp_path / "nomasks.npz", labels=np.array(["a", "b"])))
    with pytest.raises(MaskFormatError, match="dtype float32"):
        read_masks(_npz(tmp_path / "float.npz", masks=masks.astype(np.float32)))
    with pytest.raises(MaskFormatError, match=r"shape \(4, 5\)"):
        read_masks(_npz(tmp_path / "2d.npz", masks=masks[0]))
    with pytest.raises(MaskFormatError, match="3 labels for 2 masks"):
        read_masks(_npz(tmp_path / "labels.npz", masks=masks, labels=np.array(["a", "b", "c"])))
    with pytest.raises(MaskFormatError, match=r"expected \(M,\) str"):
        read_masks(_npz(tmp_path / "intlabels.npz", masks=masks, labels=np.array([1, 2])))
    objects = np.array(["a", None], dtype=object)
    with pytest.raises(MaskFormatError, match="Object arrays"):
        read_masks(_npz(tmp_path / "obj.npz", masks=masks, labels=objects))
    with pytest.raises(MaskFormatError, match="'scores' has shape"):
        read_masks(_npz(tmp_path / "scores.npz", masks=masks, scores=np.ones(3)))
    ok = _npz(tmp_path / "ok.npz", masks=masks)
    with pytest.raises(MaskFormatError, match="5x4 pixels; expected 6x4"):
        read_masks(ok, image_size=(6, 4))
    with pytest.raises(FileNotFoundError):
        read_masks(tmp_path / "missing.npz")


def test_uint8_zero_one_masks_are_accepted(tmp_path: Path) -> None:
    masks = np.zeros((1, 3, 3), dtype=np.uint8)
    masks[0, 1, 1] = 1
    ms = read_masks(_npz(tmp_path / "u8.npz", masks=masks))
    assert ms.masks.dtype == np.bool_ and int(ms.masks.sum()) == 1
    with pytest.raises(MaskFormatError, match="uint8"):
        read_masks(_npz(tmp_path / "u8bad.npz", masks=masks * 7))


def test_write_npz_is_reproducible_and_refuses_objects(tmp_path: Path) -> None:
    arrays = {"b": np.arange(5), "a": np.eye(3)}
    write_npz(tmp_path / "x.npz", arrays)
    with zipfile.ZipFile(tmp_path / "x.npz") as archive:
        infos = archive.infolist()
    assert [i.filename for i in infos] == ["a.npy", "b.npy"]
    assert all(i.date_time == (1980, 1, 1, 0, 0, 0) for i in infos)
    with pytest.raises(MaskFormatError, match="object"):
        write_npz(tmp_path / "o.npz", {"x": np.array([None])})


def test_masks_from_id_render_one_mask_per_id() -> None:
    ids = np.full((5, 6), -1)
    ids[0:2, 0:3] = 7
    ids[3:, :] = 2
    ids[1, 5] = 7
    ms = masks_from_id_render(ids, {2: "table", 7: "cup", 9: "unused"}, view="v")
    assert ms.ids is not None and ms.ids.tolist() == [2, 7]
    assert ms.labels == ("table", "cup")
    assert ms.scores is None
    np.testing.assert_array_equal(ms.masks[0], ids == 2)
    np.testing.assert_array_equal(ms.masks[1], ids == 7)
    with pytest.raises(MaskFormatError, match=r"no label for id\(s\) \[7\]"):
        masks_from_id_render(ids, {2: "table"})
    with pytest.raises(MaskFormatError, match="expected"):
        masks_from_id_render(ids.astype(np.float32), None)
    empty = masks_from_id_render(np.full((4, 3), -1), None)
    assert empty.masks.shape == (0, 4, 3)


@settings(max_examples=40, deadline=None)
@given(
    hnp.arrays(
        np.int64, st.tuples(st.integers(1, 9), st.integers(1, 9)), elements=st.integers(-1, 5)
    )
)
def test_id_map_round_trip(ids: np.ndarray) -> None:
    ms = masks_from_id_render(ids, {i: f"c{i}" for i in range(6)})
    np.testing.assert_array_equal(id_map_from_masks(ms), np.where(ids >= 0, ids, -1))


def test_id_map_needs_ids_and_disjoint_masks() -> None:
    masks = np.ones((2, 2, 2), dtype=bool)
    with pytest.raises(MaskFormatError, match="no ids"):
        id_map_from_masks(MaskSet("v", masks))
    with pytest.raises(MaskFormatError, match="overlap"):
        id_map_from_masks(MaskSet("v", masks, ids=np.array([1, 2])))


def test_read_mask_dir(tmp_path: Path) -> None:
    write_masks(tmp_path / "b.npz", _example())
    write_masks(tmp_path / "a.npz", _example())
    found = read_mask_dir(tmp_path)
    assert list(found) == ["a", "b"] and found["a"].view == "a"
    with pytest.raises(FileNotFoundError):
        read_mask_dir(tmp_path / "nope")
