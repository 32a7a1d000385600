"""The compiled kernel (``backend="numba"``): the same contributors as the numpy path, held
to the float64 reference on edge cases, independent of its thread count and of its
one-pass / two-pass mode; backend selection and the fallback without numba.

Tolerances: the sparse structure (row pointers, Gaussian indices and their order) is
equal; weights agree to float32 rounding (rtol 1e-6); against the reference the tolerances
of test_render_reference.py hold.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np
import pytest

from causalsplat.errors import MissingDependencyError
from causalsplat.io.types import Camera, GaussianScene
from causalsplat.render import RasterConfig, RenderError, _backend, build_contributors
from causalsplat.render._reference import reference_weights
from causalsplat.render.types import Contributors
from tests.causalsplat.render.conftest import make_camera, make_random_scene
from tests.causalsplat.render.test_render_reference import check_against_reference

numba = pytest.importorskip("numba")


def _build(
    scene: GaussianScene, camera: Camera, config: RasterConfig, backend: str
) -> Contributors:
    cfg = dataclasses.replace(config, backend=backend)
    return build_contributors(scene, camera, config=cfg, cache=False)


def assert_same_contributors(a: Contributors, b: Contributors) -> None:
    np.testing.assert_array_equal(a.indptr, b.indptr)
    np.testing.assert_array_equal(a.indices, b.indices)
    np.testing.assert_allclose(a.weights, b.weights, rtol=1e-6, atol=1e-30)
    np.testing.assert_array_equal(a.depths, b.depths)
    assert a.indices.dtype == b.indices.dtype == np.int32
    assert a.weights.dtype == b.weights.dtype == np.float32
    assert a.indptr.dtype == b.indptr.dtype == np.int64


KNOBS = [
    RasterConfig(),
    RasterConfig(max_contributors=1),
    RasterConfig(max_contributors=7),
    RasterConfig(transmittance_min=0.0),
    RasterConfig(transmittance_min=0.9),
    RasterConfig(tile_size=5),
    RasterConfig(low_pass=0.0, alpha_max=0.5, alpha_min=0.05),
]
KNOB_IDS = ["default", "cap1", "cap7", "tmin0", "tmin0.9", "numpy-tile5", "alpha"]
#: Kernel tile shapes (width, height): single pixels, odd sizes, square, the default,
#: wider than the image (long exp steps), tall and narrow.
TILES = [(1, 1), (5, 3), (16, 16), (128, 8), (4096, 2), (7, 64)]


@pytest.mark.parametrize("config", KNOBS, ids=KNOB_IDS)
@pytest.mark.parametrize("seed", [0, 1])
def test_kernel_equals_numpy_path(seed: int, config: RasterConfig) -> None:
    scene = make_random_scene(seed, n=400, extent=1.2, scale_range=(0.02, 0.3))
    cam = make_camera(67, 45)
    fast = _build(scene, cam, config, "numba")
    assert fast.nnz > 1000
    assert_same_contributors(fast, _build(scene, cam, config, "numpy"))


@pytest.mark.parametrize("tile", TILES, ids=[f"{w}x{h}" for w, h in TILES])
@pytest.mark.parametrize(
    "config", [RasterConfig(), RasterConfig(max_contributors=3)], ids=["default", "cap3"]
)
def test_kernel_tile_shape_changes_nothing(
    monkeypatch: pytest.MonkeyPatch, tile: tuple[int, int], config: RasterConfig
) -> None:
    from causalsplat.render import _kernel

    scene = make_random_scene(4, n=300, extent=1.0, scale_range=(0.01, 0.6))
    cam = make_camera(61, 37)
    numpy_path = _build(scene, cam, config, "numpy")
    monkeypatch.setattr(_kernel, "TILE_WIDTH", tile[0])
    monkeypatch.setattr(_kernel, "TILE_HEIGHT", tile[1])
    assert_same_contributors(_build(scene, cam, config, "numba"), numpy_path)


@pytest.mark.parametrize(
    "config",
    [RasterConfig(max_contributors=1), RasterConfig(transmittance_min=0.0),
     RasterConfig(transmittance_min=0.999), RasterConfig(max_contributors=2, tile_size=3)],
    ids=["cap1", "tmin0", "tmin0.999", "cap2-tile3"],
)  # fmt: skip
def test_kernel_matches_reference_at_the_extremes_of_the_rules(
    random_scene: Callable[..., GaussianScene], camera: Camera, config: RasterConfig
) -> None:
    scene = random_scene(11, n=60, extent=0.5, scale_range=(0.1, 0.5), logit_std=1.0)
    check_against_reference(scene, camera, config)


@pytest.mark.parametrize(
    "config",
    [RasterConfig(), RasterConfig(alpha_min=1e-12), RasterConfig(alpha_min=1e-280),
     RasterConfig(alpha_min=0.2), RasterConfig(low_pass=0.0)],
    ids=["default", "alpha_min1e-12", "alpha_min1e-280", "alpha_min0.2", "no-lowpass"],
)  # fmt: skip
def test_exp_stepped_along_rows_matches_reference_and_numpy(config: RasterConfig) -> None:
    """Wide Gaussians (x-curvature below STEP_MAX_CA) take the stepped exp along their
    rows, narrow ones (and all with alpha_min < e^-600) their own exp per pixel."""
    scene = make_random_scene(9, n=25, extent=0.6, scale_range=(0.005, 0.8), logit_std=1.0)
    cam = make_camera(70, 9)
    fast = _build(scene, cam, config, "numba")
    assert_same_contributors(fast, _build(scene, cam, config, "numpy"))
    if config.alpha_min > 1e-30:  # below, float32 weights underflow where the reference's don't
        check_against_reference(scene, cam, config)


def test_one_gaussian_covering_the_whole_image() -> None:
    cam = Camera.look_at("c", [0, -2, 0], [0, 0, 0], [0, 0, 1], 23, 17, 40)
    scene = make_random_scene(0, n=1, extent=0.01, scale_range=(30.0, 40.0), logit_std=0.0)
    contrib = _build(scene, cam, RasterConfig(), "numba")
    assert contrib.nnz == cam.width * cam.height  # every pixel, once
    check_against_reference(scene, cam, RasterConfig())
    # Under many small ones, in front and behind.
    small = make_random_scene(1, n=40, extent=1.0, scale_range=(0.02, 0.1))
    both = GaussianScene(
        np.concatenate([scene.means, small.means]),
        np.concatenate([scene.quats, small.quats]),
        np.concatenate([scene.log_scales, small.log_scales]),
        np.concatenate([scene.opacity_logits, small.opacity_logits]),
        np.concatenate([scene.sh, small.sh]),
    )
    check_against_reference(both, cam, RasterConfig())
    check_against_reference(both, cam, RasterConfig(max_contributors=1))


def test_all_pixels_empty() -> None:
    scene = make_random_scene(2, n=50)
    behind = Camera.look_at("b", [0, -3, 0], [0, -6, 0], [0, 0, 1], 21, 13, 50)
    contrib = _build(scene, behind, RasterConfig(), "numba")
    assert contrib.nnz == 0 and contrib.indptr.shape == (21 * 13 + 1,) and not contrib.indptr.any()
    assert not contrib.depths.any()
    assert_same_contributors(contrib, _build(scene, behind, RasterConfig(), "numpy"))


def test_gaussians_behind_the_camera_and_huge_and_tiny_scales() -> None:
    cam = Camera.look_at("c", [0, 0, 0], [0, 1, 0], [0, 0, 1], 24, 18, 60)
    rng = np.random.default_rng(4)
    n = 60
    means = rng.uniform(-2, 2, (n, 3))  # about half behind the camera (world y < 0)
    scales = np.exp(rng.uniform(np.log(1e-6), np.log(1e3), (n, 3)))
    scene = GaussianScene(means, rng.normal(size=(n, 4)), np.log(scales), rng.normal(size=n),
                          rng.normal(size=(n, 1, 3)))  # fmt: skip
    contrib = _build(scene, cam, RasterConfig(), "numba")
    assert set(np.unique(contrib.indices)) <= set(np.flatnonzero(means[:, 1] >= 0.01))
    check_against_reference(scene, cam, RasterConfig())


def test_thread_count_does_not_change_the_output() -> None:
    scene = make_random_scene(3, n=500, extent=1.0, scale_range=(0.02, 0.2))
    cam = make_camera(80, 61)
    one = _build(scene, cam, RasterConfig(threads=1), "numba")
    two = _build(scene, cam, RasterConfig(threads=2), "numba")
    for name in ("indptr", "indices", "weights", "depths"):
        np.testing.assert_array_equal(getattr(one, name), getattr(two, name))


def test_thread_count_defaults_to_the_available_cores_within_numbas_limit(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from causalsplat.render import _kernel

    monkeypatch.setattr(_kernel, "available_cores", lambda: 3)
    monkeypatch.setattr(numba.config, "NUMBA_NUM_THREADS", 8)
    assert _kernel.thread_count(RasterConfig()) == 3
    assert _kernel.thread_count(RasterConfig(threads=5)) == 5
    monkeypatch.setattr(numba.config, "NUMBA_NUM_THREADS", 2)
    assert _kernel.thread_count(RasterConfig(threads=5)) == 2


def test_two_pass_mode_and_overflow_fallback_give_the_same_output(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from causalsplat.render import _kernel

    scene = make_random_scene(5, n=300, extent=0.8, scale_range=(0.05, 0.3))
    cam = make_camera(50, 40)
    one_pass = _build(scene, cam, RasterConfig(max_contributors=9), "numba")
    monkeypatch.setattr(_kernel, "SCRATCH_BYTES", 0)
    assert_same_contributors(
        one_pass, _build(scene, cam, RasterConfig(max_contributors=9), "numba")
    )
    monkeypatch.undo()
    # Regions too small for their tiles (the bound rules this out): flagged, then redone.
    real_tiles = _kernel._Tiles

    class ShortTiles(real_tiles):  # type: ignore[misc,valid-type]
        def __init__(self, *args: object) -> None:
            super().__init__(*args)
            self.bound //= 3

    monkeypatch.setattr(_kernel, "_Tiles", ShortTiles)
    assert_same_contributors(
        one_pass, _build(scene, cam, RasterConfig(max_contributors=9), "numba")
    )


def test_backend_selection_and_fallback_without_numba(monkeypatch: pytest.MonkeyPatch) -> None:
    assert _backend.resolve_backend(RasterConfig()) == "numba"
    assert _backend.resolve_backend(RasterConfig(backend="numpy")) == "numpy"
    scene, cam = make_random_scene(6, n=40), make_camera()
    monkeypatch.setattr(_backend, "numba_available", lambda: False)
    assert _backend.resolve_backend(RasterConfig()) == "numpy"
    auto = build_contributors(scene, cam, cache=False)
    assert_same_contributors(auto, _build(scene, cam, RasterConfig(), "numpy"))
    with pytest.raises(MissingDependencyError, match=r"pip install 'causalsplat\[build\]'"):
        _build(scene, cam, RasterConfig(), "numba")


@pytest.mark.parametrize(
    ("field", "value"),
    [("backend", "cuda"), ("backend", None), ("threads", 0), ("threads", -2), ("threads", True),
     ("threads", 1.5)],
)  # fmt: skip
def test_bad_backend_or_thread_count_is_a_render_error(field: str, value: object) -> None:
    with pytest.raises(RenderError, match=f"RasterConfig.{field}="):
        RasterConfig(**{field: value})  # type: ignore[arg-type]


def test_thread_count_is_not_part_of_the_cache_key() -> None:
    scene, cam = make_random_scene(7, n=30), make_camera()
    first = build_contributors(scene, cam, config=RasterConfig(threads=1))
    assert build_contributors(scene, cam, config=RasterConfig(threads=2)) is first
    assert build_contributors(scene, cam, config=RasterConfig(backend="numpy")) is not first


def test_float64_matrix_keeps_the_row_order() -> None:
    scene, cam = make_random_scene(8, n=80, extent=0.5), make_camera()
    contrib = build_contributors(scene, cam, cache=False)
    m64 = contrib.matrix(np.float64)
    assert m64.dtype == np.float64
    np.testing.assert_array_equal(m64.indices, contrib.indices)  # front to back, not re-sorted
    np.testing.assert_array_equal(m64.toarray(), contrib.matrix().astype(np.float64).toarray())
    assert np.shares_memory(contrib.matrix().data, contrib.weights)  # float32: no copy
    np.testing.assert_allclose(m64.toarray(), reference_weights(scene, cam), atol=1e-6)


def test_jit_compiles_without_a_cache_where_none_can_be_written(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from causalsplat.render import _jit

    real = numba.njit

    def no_cache_dir(**options: object) -> Callable[..., object]:
        if options.get("cache"):
            raise RuntimeError("cannot cache function 'f': no locator available for file")
        return real(**options)  # type: ignore[no-any-return]

    monkeypatch.setattr(_jit.numba, "njit", no_cache_dir)

    @_jit.jit()
    def twice(x: float) -> float:
        return 2.0 * x

    assert twice(2.5) == 5.0
