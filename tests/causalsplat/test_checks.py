"""The shared config check: intervals, their text, and the messages every config gives."""

from __future__ import annotations

import math

import pytest

from causalsplat._checks import Interval, check_fields
from causalsplat.field import FieldConfig, FieldConfigError
from causalsplat.graph.config import EdgeConfig
from causalsplat.graph.errors import EdgeConfigError
from causalsplat.instances import InstanceConfig
from causalsplat.instances.config import InstanceConfigError
from causalsplat.render import RasterConfig, RenderError


@pytest.mark.parametrize(
    ("interval", "inside", "outside", "text"),
    [
        (Interval(0, 1), [0, 0.5, 1], [-1e-9, 1.0000001, math.nan, math.inf, True], "[0, 1]"),
        (Interval(0, 1, low_open=True, high_open=True), [1e-12, 0.5], [0, 1], "(0, 1)"),
        (Interval(2, integer=True), [2, 10**9], [1, 2.0, 2.5, False], "integer in [2, inf)"),
        (Interval(0, infinite=True), [0, 3.5, math.inf], [-math.inf, -1, math.nan], "[0, inf]"),
        (Interval(None, 0.25), [-1e300, 0.25], [0.3, -math.inf, "0"], "(-inf, 0.25]"),
    ],
)
def test_interval_membership_and_text(
    interval: Interval, inside: list[object], outside: list[object], text: str
) -> None:
    assert all(v in interval for v in inside)
    assert not any(v in interval for v in outside)
    assert str(interval) == text


@pytest.mark.parametrize(
    ("make", "error", "message"),
    [
        (lambda: FieldConfig(w_min=1.5), FieldConfigError,
         r"^FieldConfig\.w_min must be in \[0, 1\], got 1\.5$"),
        (lambda: FieldConfig(init="zeros"), FieldConfigError,
         r"^FieldConfig\.init must be one of uplift, random, got 'zeros'$"),
        (lambda: InstanceConfig(min_cluster_size=1), InstanceConfigError,
         r"^InstanceConfig\.min_cluster_size must be an integer in \[2, inf\), got 1$"),
        (lambda: RasterConfig(far=0.001), RenderError,
         r"^RasterConfig\.far must be in \(0\.01, inf\), got 0\.001$"),
        (lambda: EdgeConfig(horizontal_max_fraction=0.01), EdgeConfigError,
         r"^EdgeConfig\.horizontal_max_fraction must be in \[0\.08, inf\), got 0\.01$"),
    ],
)  # fmt: skip
def test_every_config_names_the_allowed_range(make: object, error: type, message: str) -> None:
    with pytest.raises(error, match=message):
        make()  # type: ignore[operator]


def test_check_fields_reports_the_first_bad_field_only() -> None:
    allowed = {"a": Interval(0), "b": ("x", "y")}
    check_fields("T", {"a": 1, "b": "x"}, allowed, ValueError)
    with pytest.raises(ValueError, match=r"^T\.b must be one of x, y, got 3$"):
        check_fields("T", {"a": 1, "b": 3}, allowed, ValueError)
