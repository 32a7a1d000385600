"""The views a build lifts masks through stop compositing at 1 % of the light left
(``causalsplat.field.lift.LIFT_TRANSMITTANCE_MIN``), not at the 1e-4 of a rendered image:
a Gaussian hidden behind 99 % opacity gets no blending weight, hence no vote in the
masks drawn over it."""

from __future__ import annotations

import numpy as np
import pytest

from causalsplat.build import BuildConfig
from causalsplat.field import FieldConfig, prepare_views
from causalsplat.field.lift import LIFT_RASTER, LIFT_TRANSMITTANCE_MIN
from causalsplat.io.types import Camera, GaussianScene
from causalsplat.masks import MaskSet
from causalsplat.render import RasterConfig


def _logit(p: float) -> float:
    return float(np.log(p / (1 - p)))


def _stack(front_opacity: float) -> tuple[GaussianScene, Camera]:
    """A wide Gaussian on the optical axis 2 units from the camera, a second one
    1 unit behind it: the front one covers every pixel."""
    scene = GaussianScene(
        means=np.array([[0.0, 0.0, 0.0], [0.0, 1.0, 0.0]]),
        quats=np.tile([1.0, 0.0, 0.0, 0.0], (2, 1)),
        log_scales=np.log(np.full((2, 3), 30.0)),  # flat over the view
        opacity_logits=np.array([_logit(front_opacity), _logit(0.5)]),
        sh=np.zeros((2, 1, 3)),
    )
    cam = Camera.look_at("cam", [0.0, -2.0, 0.0], [0, 0, 0], [0, 0, 1], 8, 6, 30)
    return scene, cam


def _hidden_weight(front_opacity: float, raster: RasterConfig | None) -> float:
    """The blending weight the back Gaussian carries in a mask covering the whole view."""
    scene, cam = _stack(front_opacity)
    masks = MaskSet("cam", np.ones((1, cam.height, cam.width), dtype=bool))
    kw = {} if raster is None else {"raster": raster}
    views = prepare_views(scene, [cam], [masks], FieldConfig(iterations=0), **kw)
    weights = views.contributors[0].matrix(np.float64)
    return float(weights[:, 1].sum())


def test_a_gaussian_behind_99_percent_opacity_gets_no_weight_when_lifting() -> None:
    # alpha is clamped at 0.99: the back Gaussian would leave 0.01 * 0.5 of the light
    assert _hidden_weight(0.999, None) == 0.0
    assert _hidden_weight(0.999, LIFT_RASTER) == 0.0
    # a rendered image (RasterConfig's 1e-4) keeps it, with its 0.005 of each pixel
    assert _hidden_weight(0.999, RasterConfig()) == pytest.approx(0.005 * 48, rel=1e-3)
    # behind a front that lets 2 % through it is still seen (a little more: the front
    # thins towards the corners)
    assert _hidden_weight(0.98, None) == pytest.approx(0.02 * 0.5 * 48, rel=0.02)


def test_a_build_lifts_with_the_lift_raster_unless_its_config_says_otherwise() -> None:
    assert BuildConfig().raster == LIFT_RASTER
    assert LIFT_RASTER.transmittance_min == LIFT_TRANSMITTANCE_MIN == 0.01
    assert RasterConfig().transmittance_min == 1e-4  # images render as 3DGS does
    # a raster section sets only what it names: the rest is the build's own default
    capped = BuildConfig.from_json({"raster": {"max_contributors": 64}})
    assert capped.raster == RasterConfig(transmittance_min=0.01, max_contributors=64)
    image = BuildConfig.from_json({"raster": {"transmittance_min": 1e-4}})
    assert image.raster.transmittance_min == 1e-4
    # the stage caches and the scene's config hash tell the two apart
    assert image.result_json()["raster"] != BuildConfig().result_json()["raster"]
