"""Colour in CIELAB: names of a measured colour, colour words, hex round trips."""

from __future__ import annotations

import numpy as np
import pytest

from causalsplat.colors import (
    BASIC,
    WORDS,
    hex_to_rgb,
    is_color_word,
    mean_color,
    names_of,
    rgb_to_hex,
    srgb_to_lab,
    word_distance,
    word_fits,
)


@pytest.mark.parametrize("name", sorted(BASIC))
def test_basic_terms_name_themselves_also_when_shaded(name: str) -> None:
    rgb = np.array(BASIC[name])
    assert names_of(rgb)[0] == name
    if name not in ("white", "gray", "black", "beige"):  # shading moves lightness only
        assert names_of(0.85 * rgb)[0] == name


def test_lab_matches_a_float64_reference_at_the_extremes() -> None:
    # sRGB primaries and black/white in CIELAB D65 (standard values)
    ref = {(0, 0, 0): (0, 0, 0), (1, 1, 1): (100, 0, 0), (1, 0, 0): (53.24, 80.09, 67.20),
           (0, 1, 0): (87.73, -86.18, 83.18), (0, 0, 1): (32.30, 79.19, -107.86)}  # fmt: skip
    for rgb, lab in ref.items():
        assert srgb_to_lab(rgb) == pytest.approx(lab, abs=0.05)
    # out-of-range input is clipped, never NaN
    assert np.isfinite(srgb_to_lab([[-1e300, 2.0, np.float64(1e308)]])).all()


def test_words_by_distance_never_by_string() -> None:
    navy = hex_to_rgb("#0c1470")
    assert navy is not None
    assert word_distance("navy", navy) < word_distance("blue", navy) < word_distance("red", navy)
    assert word_fits("navy", navy) and not word_fits("yellow", navy)
    # a light and a dark blue: "light blue" is nearer the first, "dark blue" the second
    light, dark = (0.55, 0.7, 0.95), (0.05, 0.1, 0.35)
    assert word_distance("blue", light, "light") < word_distance("blue", dark, "light")
    assert word_distance("blue", dark, "dark") < word_distance("blue", light, "dark")
    assert is_color_word("reddish") and is_color_word("greyish") and not is_color_word("chair")
    assert word_distance("chair", navy) == float("inf")
    assert all(is_color_word(w) for w in WORDS)


def test_hex_round_trip_and_weighted_mean() -> None:
    for rgb in ((0, 0, 0), (1, 1, 1), (0.2, 0.4, 0.6)):
        back = hex_to_rgb(rgb_to_hex(rgb))
        assert back == pytest.approx(rgb, abs=0.5 / 255 + 1e-12)
    assert hex_to_rgb("red") is None and hex_to_rgb("#12345") is None
    assert mean_color(np.zeros((0, 3))) is None
    assert mean_color(np.ones((2, 3)), np.zeros(2)) is None
    m = mean_color(np.array([[1.0, 0, 0], [0, 0, 1.0]]), np.array([3.0, 1.0]))
    assert m is not None and m.tolist() == pytest.approx([0.75, 0.0, 0.25])
