"""3DGS PLY reading and writing: the real INRIA sample, round trips, extra properties, bad files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from plyfile import PlyData, PlyElement

from causalsplat.io import (
    SH_C0,
    GaussianScene,
    PlyFormatError,
    read_gaussian_ply,
    read_ply,
    write_ply,
)
from tests.conftest import shared_data_path


def _sample() -> Path:
    return shared_data_path("inria_3dgs_ply_sample", "point_cloud_iter7000.ply")


@pytest.mark.shared_data
def test_real_sample_round_trip_is_byte_exact(tmp_path: Path) -> None:
    src = _sample()
    ply = read_gaussian_ply(src)
    assert ply.scene.n == 9080 and ply.scene.sh_degree == 3
    assert sorted(ply.extra) == ["nx", "ny", "nz"]
    out = tmp_path / "copy.ply"
    write_ply(out, ply.scene, extra=ply.extra, layout=ply.layout)
    assert out.read_bytes() == src.read_bytes()
    # The INRIA default layout reproduces the file as well (it was written that way).
    write_ply(tmp_path / "default.ply", ply.scene)
    assert (tmp_path / "default.ply").read_bytes() == src.read_bytes()


@pytest.mark.shared_data
def test_real_sample_activations_and_sh_layout() -> None:
    src = _sample()
    raw = PlyData.read(str(src))["vertex"].data
    scene = read_ply(src)
    i = 1234
    np.testing.assert_array_equal(scene.means[i], [raw["x"][i], raw["y"][i], raw["z"][i]])
    # f_rest is channel-major: f_rest_{c*15 + j} is coefficient j+1 of channel c.
    for c in range(3):
        for j in range(15):
            assert scene.sh[i, j + 1, c] == raw[f"f_rest_{c * 15 + j}"][i]
    dc = np.array([raw[f"f_dc_{c}"][i] for c in range(3)], dtype=np.float64)
    np.testing.assert_allclose(scene.colors[i], np.clip(0.5 + 0.28209479 * dc, 0, 1), atol=1e-6)
    assert pytest.approx(0.28209479) == SH_C0
    np.testing.assert_allclose(
        scene.opacities[i], 1 / (1 + np.exp(-float(raw["opacity"][i]))), rtol=1e-6
    )
    np.testing.assert_allclose(
        scene.scales[i], np.exp([raw[f"scale_{k}"][i] for k in range(3)]), rtol=1e-6
    )
    q = np.array([raw[f"rot_{k}"][i] for k in range(4)], dtype=np.float64)
    np.testing.assert_allclose(scene.rotations[i], q / np.linalg.norm(q), rtol=1e-6)
    np.testing.assert_allclose(np.linalg.norm(scene.rotations, axis=1), 1.0, rtol=1e-12)
    rot = scene.rotation_matrices
    np.testing.assert_allclose(
        rot @ rot.transpose(0, 2, 1), np.broadcast_to(np.eye(3), rot.shape), atol=1e-12
    )


@pytest.mark.shared_data
def test_writing_entity_id_adds_the_property(tmp_path: Path) -> None:
    ply = read_gaussian_ply(_sample())
    ids = np.arange(ply.scene.n, dtype=np.int64) % 17 - 1
    out = tmp_path / "ids.ply"
    write_ply(out, ply.scene, extra={**ply.extra, "entity_id": ids}, layout=ply.layout)
    back = read_gaussian_ply(out)
    names = [n for n, _ in back.layout.properties]
    assert names == [n for n, _ in ply.layout.properties] + ["entity_id"]
    assert back.layout.properties[-1] == ("entity_id", "<i4")
    np.testing.assert_array_equal(back.extra["entity_id"], ids)
    np.testing.assert_array_equal(back.scene.sh, ply.scene.sh)
    np.testing.assert_array_equal(back.scene.quats, ply.scene.quats)


@st.composite
def scenes(draw: st.DrawFn) -> GaussianScene:
    n = draw(st.integers(0, 20))
    degree = draw(st.integers(0, 3))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    return GaussianScene(
        means=rng.normal(size=(n, 3)) * 100,
        quats=rng.normal(size=(n, 4)) + np.array([3.0, 0, 0, 0]),
        log_scales=rng.normal(size=(n, 3)),
        opacity_logits=rng.normal(size=n) * 5,
        sh=rng.normal(size=(n, (degree + 1) ** 2, 3)),
    )


@settings(
    max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(scene=scenes(), text=st.booleans())
def test_write_read_round_trip(tmp_path: Path, scene: GaussianScene, text: bool) -> None:
    from causalsplat.io.ply import default_layout

    ids = np.arange(scene.n, dtype=np.int32) * 3
    layout = default_layout(scene.sh_degree, {"entity_id": ids})
    if text:
        from dataclasses import replace

        layout = replace(layout, text=True)
    path = tmp_path / "scene.ply"
    write_ply(path, scene, extra={"entity_id": ids}, layout=layout)
    back = read_gaussian_ply(path)
    for name in ("means", "quats", "log_scales", "opacity_logits", "sh"):
        np.testing.assert_array_equal(getattr(back.scene, name), getattr(scene, name))
    np.testing.assert_array_equal(back.extra["entity_id"], ids)
    again = tmp_path / "again.ply"
    write_ply(again, back.scene, extra=back.extra, layout=back.layout)
    assert again.read_bytes() == path.read_bytes()


def _write_raw(path: Path, columns: dict[str, np.ndarray]) -> Path:
    table = np.empty(len(next(iter(columns.values()))), dtype=[(k, "f4") for k in columns])
    for k, v in columns.items():
        table[k] = v
    PlyData([PlyElement.describe(table, "vertex")]).write(str(path))
    return path


def _columns(n: int = 4, n_rest: int = 0) -> dict[str, np.ndarray]:
    names = ["x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2"]
    names += [f"f_rest_{i}" for i in range(n_rest)]
    names += ["opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"]
    cols = {k: np.zeros(n, np.float32) for k in names}
    cols["rot_0"][:] = 1.0
    return cols


def test_bad_files_raise_typed_errors_naming_file_and_property(tmp_path: Path) -> None:
    good = _write_raw(tmp_path / "good.ply", _columns(n_rest=9))
    assert read_ply(good).sh_degree == 1

    cut = tmp_path / "truncated.ply"
    cut.write_bytes(good.read_bytes()[:-10])
    with pytest.raises(PlyFormatError, match=r"truncated.ply"):
        read_ply(cut)

    cols = _columns()
    del cols["opacity"]
    with pytest.raises(PlyFormatError, match=r"missing.ply: vertex property 'opacity' is missing"):
        read_ply(_write_raw(tmp_path / "missing.ply", cols))

    cols = _columns()
    cols["y"][2] = np.nan
    with pytest.raises(PlyFormatError, match=r"nan.ply: vertex property 'y' has 1 NaN.*vertex 2"):
        read_ply(_write_raw(tmp_path / "nan.ply", cols))

    with pytest.raises(PlyFormatError, match=r"sh.ply: 10 f_rest_\* properties"):
        read_ply(_write_raw(tmp_path / "sh.ply", _columns(n_rest=10)))

    cols = _columns()
    cols["rot_0"][1] = 0.0
    with pytest.raises(PlyFormatError, match=r"quat.ply: rot_0..rot_3: .*zero quaternion"):
        read_ply(_write_raw(tmp_path / "quat.ply", cols))

    junk = tmp_path / "junk.ply"
    junk.write_bytes(b"not a ply at all\n")
    with pytest.raises(PlyFormatError, match=r"junk.ply"):
        read_ply(junk)
    with pytest.raises(PlyFormatError, match=r"absent.ply"):
        read_ply(tmp_path / "absent.ply")


@pytest.mark.shared_data
def test_truncated_real_sample(tmp_path: Path) -> None:
    data = _sample().read_bytes()
    for keep in (len(data) // 2, 300):
        cut = tmp_path / f"cut{keep}.ply"
        cut.write_bytes(data[:keep])
        with pytest.raises(PlyFormatError, match=f"cut{keep}.ply"):
            read_ply(cut)


def test_a_count_beyond_the_file_is_refused_before_allocating(tmp_path: Path) -> None:
    """A header that declares 2e9 vertices (496 GB of rows) over a 2 MB body."""
    data = _sample().read_bytes()
    head, sep, body = data.partition(b"end_header\n")
    lines = [b"element vertex 2000000000" if line.startswith(b"element vertex") else line
             for line in head.split(b"\n")]  # fmt: skip
    huge = tmp_path / "huge.ply"
    huge.write_bytes(b"\n".join(lines) + sep + body)
    with pytest.raises(PlyFormatError, match=r"huge.ply: the header declares 496,000,000,000"):
        read_ply(huge)


def test_bytes_after_the_declared_rows_are_refused(tmp_path: Path) -> None:
    """A real capture with one more (partial) row appended, or a count one too small: the
    rest of the file would be dropped without a word."""
    data = _sample().read_bytes()
    longer = tmp_path / "longer.ply"
    longer.write_bytes(data + b"\x00" * 7)
    with pytest.raises(PlyFormatError, match=r"longer.ply: 7 bytes follow the .* declares"):
        read_ply(longer)
    head, sep, body = data.partition(b"end_header\n")
    n = int(next(x for x in head.split(b"\n") if x.startswith(b"element vertex")).split()[2])
    short = tmp_path / "short.ply"
    short.write_bytes(head.replace(b"element vertex %d" % n, b"element vertex %d" % (n - 1))
                      + sep + body)  # fmt: skip
    with pytest.raises(PlyFormatError, match="bytes follow"):
        read_ply(short)
