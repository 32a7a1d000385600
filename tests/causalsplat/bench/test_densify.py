"""Densified scenes: the copies of a Gaussian render as the Gaussian did.

The rendering check runs the real rasterizer on the tiny synthetic room; the opacity
rule is checked against a 1,200-digit reference on logits far beyond float64's sigmoid.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp

from causalsplat.bench._densify import densify_folder, split_opacity_logits
from causalsplat.build.folder import read_scene_folder
from causalsplat.render import build_contributors

mpmath = pytest.importorskip("mpmath")


@pytest.mark.parametrize("copies", [2, 8, 18, 1000])
def test_split_opacity_matches_a_high_precision_reference(copies: int) -> None:
    """``1 - (1 - a') ** k = a`` in 1,200-digit arithmetic, for logits whose sigmoid is 0
    or 1 in float64 (-800, 800) as well as ordinary ones."""
    logits = np.array([-800.0, -745.0, -700.0, -40.0, -5.0, 0.0, 5.0, 36.0, 40.0, 700.0, 800.0])
    got = split_opacity_logits(logits, copies)
    with mpmath.workdps(1200):
        for value, out in zip(logits.tolist(), got.tolist(), strict=True):
            a = 1 / (1 + mpmath.exp(-mpmath.mpf(value)))
            each = 1 - (1 - a) ** (mpmath.mpf(1) / copies)
            ref = float(mpmath.log(each / (1 - each)))
            assert np.isfinite(out)
            assert abs(out - ref) <= 1e-13 * max(1.0, abs(ref)), (value, out, ref)
    assert np.all(np.diff(got) > 0)  # the order of the opacities is kept


def test_split_opacity_rejects_no_copies() -> None:
    with pytest.raises(ValueError, match=r"copies must be in \[1, inf\), got 0"):
        split_opacity_logits(np.zeros(3), 0)


def _front_objects(folder: Path) -> list[np.ndarray]:
    """Per view, the GT object carrying most of each pixel's blending weight (-1 where the
    scene draws less than half a pixel)."""
    scene = read_scene_folder(folder, max_views=4)
    gt = np.load(folder / "gt" / "gt_labels.npy")
    onehot = sp.csr_matrix((np.ones(gt.size), (np.arange(gt.size), gt + 1)))
    out = []
    for camera in scene.cameras:
        per = (build_contributors(scene.gaussians, camera, cache=False).matrix(np.float64)
               @ onehot).toarray()  # fmt: skip
        out.append(np.where(per.sum(axis=1) > 0.5, per.argmax(axis=1), -1))
    return out


def test_kept_opacity_renders_the_objects_where_the_masks_are(tmp_path: Path) -> None:
    """Eight copies each as opaque as the original draw a thicker scene: the object in
    front changes on more pixels than with the opacity shared among the copies, which
    departs from the original only by the jitter's blur."""
    from causalsplat.synth import synth_scene

    original = tmp_path / "original"
    synth_scene("tiny", 0, original)
    base = _front_objects(original)
    changed = {}
    for rule in ("kept", "each"):
        dense = densify_folder(original, tmp_path / rule, 8, 0.5, opacity=rule)  # type: ignore[arg-type]
        views = _front_objects(dense)
        drawn = sum(int((b >= 0).sum()) for b in base)
        changed[rule] = (
            sum(int(((v != b) & (b >= 0)).sum()) for v, b in zip(views, base, strict=True)) / drawn
        )
    assert changed["kept"] < 0.05
    assert changed["each"] > 1.5 * changed["kept"]


@pytest.mark.parametrize(
    ("copies", "jitter", "opacity", "message"),
    [
        (2, 0.5, "half", r"densify_folder\.opacity must be one of kept, each, got 'half'"),
        (0, 0.5, "kept", r"densify_folder\.copies must be an integer in \[1, inf\), got 0"),
        (2, -1.0, "kept", r"densify_folder\.jitter must be in \[0, inf\), got -1\.0"),
    ],
)
def test_bad_arguments_are_refused_before_anything_is_written(
    tmp_path: Path, copies: int, jitter: float, opacity: str, message: str
) -> None:
    from causalsplat.synth import synth_scene

    synth_scene("tiny", 0, tmp_path / "original")
    with pytest.raises(ValueError, match=message):
        densify_folder(tmp_path / "original", tmp_path / "out", copies, jitter,
                       opacity=opacity)  # type: ignore[arg-type]  # fmt: skip
    assert not (tmp_path / "out").exists()
