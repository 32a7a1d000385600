"""Public render API: caching by content, id maps, depth, camera convention, light imports."""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Callable

import numpy as np
import pytest

from causalsplat.io.types import SH_C0, Camera, GaussianScene
from causalsplat.render import (
    RasterConfig,
    RenderError,
    build_contributors,
    clear_contributor_cache,
    contributor_cache_info,
    render_depth,
    render_ids,
    render_rgb,
    set_contributor_cache_limit,
)


def test_contributors_are_cached_by_content(
    random_scene: Callable[..., GaussianScene], camera: Camera
) -> None:
    clear_contributor_cache()
    scene = random_scene(0)
    first = build_contributors(scene, camera)
    # An equal scene built from copies hits the cache; colours do not enter the key.
    twin = GaussianScene(
        scene.means.copy(),
        scene.quats.copy(),
        scene.log_scales.copy(),
        scene.opacity_logits.copy(),
        scene.sh * 2,
    )
    assert build_contributors(twin, camera) is first
    moved = GaussianScene(
        scene.means + 1e-3, scene.quats, scene.log_scales, scene.opacity_logits, scene.sh
    )
    assert build_contributors(moved, camera) is not first
    assert build_contributors(scene, camera, config=RasterConfig(max_contributors=2)) is not first
    assert contributor_cache_info()[0] == 3
    set_contributor_cache_limit(first.nbytes)
    assert contributor_cache_info()[0] == 1
    set_contributor_cache_limit(512 * 2**20)
    clear_contributor_cache()
    assert contributor_cache_info() == (0, 0)


def test_known_point_lights_the_pixel_it_projects_to() -> None:
    cam = Camera("k", 40, 30, 50.0, 60.0, 17.0, 11.0, np.eye(4))
    point = np.array([[0.3, -0.1, 2.0]])
    u, v = 50 * 0.3 / 2 + 17, 60 * -0.1 / 2 + 11  # 24.5, 8.0
    np.testing.assert_allclose(cam.project(point).pixels, [[u, v]])
    scene = GaussianScene.from_points(point, np.array([[1.0, 1.0, 1.0]]), 1e-6, opacity=0.9)
    alpha = build_contributors(scene, cam).alpha()
    row, col = np.unravel_index(np.argmax(alpha), alpha.shape)
    assert (col, row) == (24, 7) or (col, row) == (24, 8)  # pixel centres (24.5, 7.5|8.5)
    assert alpha[7, 24] == pytest.approx(alpha[8, 24], rel=1e-6)  # v = 8.0 is their border
    # 0.5 px from the centre of a Gaussian whose screen variance is the 0.3 px² low-pass.
    assert alpha[8, 24] == pytest.approx(0.9 * np.exp(-0.5 * 0.25 / 0.3), rel=1e-5)


def test_render_rgb_of_a_dc_only_scene_matches_its_colours() -> None:
    cam = Camera.look_at("c", [0, -2, 0], [0, 0, 0], [0, 0, 1], 16, 16, 40)
    colors = np.array([[0.9, 0.2, 0.1]])
    scene = GaussianScene.from_points(np.zeros((1, 3)), colors, 100.0, opacity=1 - 1e-6)
    rgb = render_rgb(scene, cam)
    # A huge opaque Gaussian: every pixel gets alpha 0.99 of the colour.
    np.testing.assert_allclose(rgb, np.broadcast_to(0.99 * colors, rgb.shape), atol=1e-4)
    np.testing.assert_allclose(scene.colors, colors, atol=1e-6)
    np.testing.assert_allclose(0.5 + SH_C0 * scene.sh[:, 0], colors, atol=1e-6)


def test_depth_and_ids_of_two_layers() -> None:
    cam = Camera.look_at("c", [0, -4, 0], [0, 0, 0], [0, 0, 1], 13, 11, 60)
    means = np.array([[0.0, -1.0, 0.0], [0.0, 1.0, 0.0]])  # depths 3 and 5
    scene = GaussianScene.from_points(means, np.full((2, 3), 0.5), [0.05, 10.0], opacity=0.999)
    depth = render_depth(scene, cam)
    ids = render_ids(scene, cam, np.array([7, 9]))
    # Pixel (5, 6) is centred on both means: both alphas clamp to 0.99.
    w_front, w_back = 0.99, 0.01 * 0.99
    assert depth[5, 6] == pytest.approx((3 * w_front + 5 * w_back) / (w_front + w_back), rel=1e-6)
    assert ids[5, 6] == 7
    assert depth[0, 0] == pytest.approx(5.0, rel=1e-6) and ids[0, 0] == 9
    assert (render_ids(scene, cam, np.array([7, -1]))[0, 0]) == -1  # negative id -> -1
    assert (render_ids(scene, cam, np.array([7, 9]), min_alpha=0.99995) == -1).all()
    with pytest.raises(RenderError, match="ids"):
        render_ids(scene, cam, np.array([1.5, 2.0]))


def test_config_is_validated() -> None:
    with pytest.raises(RenderError, match="alpha_max"):
        RasterConfig(alpha_max=1.5)
    with pytest.raises(RenderError, match="max_contributors"):
        RasterConfig(max_contributors=0)


def test_render_and_io_import_without_torch() -> None:
    code = (
        "import sys, numpy as np\n"
        "import causalsplat, causalsplat.io, causalsplat.render\n"
        "from causalsplat.io import Camera, GaussianScene\n"
        "from causalsplat.render import render_rgb, render_ids\n"
        "s = GaussianScene.from_points(np.zeros((1, 3)), np.ones((1, 3)) * .5, .1)\n"
        "c = Camera.look_at('c', [0, -2, 0], [0, 0, 0], [0, 0, 1], 8, 8, 40)\n"
        "render_rgb(s, c); render_ids(s, c, np.zeros(1, dtype=int))\n"
        "assert 'torch' not in sys.modules, 'torch was imported'\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
