"""Densified scenes (tests and the scale benchmark): every Gaussian copied with a small jitter.

Real 3DGS scenes hold many overlapping near-duplicate Gaussians (densification clones and
splits them). Copying each Gaussian of a synthetic scene ``copies`` times reproduces that:
the copies are moved by ``jitter`` times the Gaussian's largest scale (normal noise), and
the first two copies stay exactly on the original (duplicates at zero distance).

A trained scene still renders the images it was fitted to, however many Gaussians make a
surface: its overlapping Gaussians are each far less opaque than a surface (the median
opacity of a trained INRIA scene is about 0.06). So by default (``opacity="kept"``) each
copy gets the opacity ``1 - (1 - a) ** (1 / copies)``: the ``copies`` of a Gaussian of
opacity ``a`` stacked on one pixel let through what it let through, and the scene renders
as before, up to the jitter's blur. ``opacity="each"`` keeps every copy as opaque as its
original (the construction of the benchmarks before 2026-12-01): the copies then render a
thicker, dilated scene (each object's outline grows by about the jitter) that no longer
matches the masks drawn from the original, so it measures that mismatch as much as the
density.
"""

from __future__ import annotations

import dataclasses
import shutil
from pathlib import Path
from typing import Literal, get_args

import numpy as np

from causalsplat._checks import Interval, check_fields

#: How ``densify_folder`` sets the copies' opacity (module docstring).
OpacityRule = Literal["kept", "each"]
OPACITY_RULES: tuple[str, ...] = get_args(OpacityRule)


def densify_centres(
    means: np.ndarray, scales: np.ndarray, copies: int, jitter: float, seed: int = 0
) -> tuple[np.ndarray, np.ndarray]:
    """(N * copies, 3) float64 jittered copies of the (N, 3) ``means``, and the (N * copies,)
    index of each copy's original; ``scales`` (N, 3) standard deviations."""
    rng = np.random.default_rng(seed)
    origin = np.repeat(np.arange(means.shape[0]), copies)
    size = np.asarray(scales, dtype=np.float64).max(axis=1)
    noise = rng.normal(size=(origin.size, 3)) * (jitter * size)[origin, None]
    noise[(np.arange(origin.size) % copies) < 2] = 0.0
    return np.asarray(means, dtype=np.float64)[origin] + noise, origin


def split_opacity_logits(logits: np.ndarray, copies: int) -> np.ndarray:
    """Opacity logits of each of ``copies`` stacked copies that together are as opaque as
    one Gaussian of ``logits``: ``a' = 1 - (1 - a) ** (1 / copies)``, ``a = sigmoid(l)``.

    Computed through ``s = log(1 + e^l) = -log(1 - a)`` so that logits far beyond the range
    where ``a`` rounds to 0 or 1 keep their order: ``l' = log(-expm1(-s / k)) + s / k``.
    Float64 out.

    >>> l = np.array([-3.0, 0.0, 2.2])
    >>> a = 1 / (1 + np.exp(-l))
    >>> a2 = 1 / (1 + np.exp(-split_opacity_logits(l, 4)))
    >>> np.allclose(1 - (1 - a2) ** 4, a)
    True
    >>> split_opacity_logits(np.array([1.5]), 1).tolist()
    [1.5]
    """
    if copies < 1:
        raise ValueError(f"copies must be in [1, inf), got {copies}")
    lg = np.asarray(logits, dtype=np.float64)
    if copies == 1:
        return lg.copy()
    s = np.logaddexp(0.0, lg) / copies  # -log(1 - a') of each copy
    with np.errstate(divide="ignore"):
        # a' = -expm1(-s); for s below ~1e-308 it underflows: then l' = l - log(copies)
        out = np.log(-np.expm1(-s)) + s
    tiny = ~np.isfinite(out)
    out[tiny] = lg[tiny] - np.log(copies)
    return out


def densify_folder(
    src: Path,
    dst: Path,
    copies: int,
    jitter: float,
    seed: int = 0,
    *,
    opacity: OpacityRule = "kept",
) -> Path:
    """Copy the scene folder ``src`` to ``dst`` with its PLY densified (module docstring)
    and its GT labels (``gt/gt_labels.npy``, when present) repeated to match. Raises
    ``ValueError``, writing nothing, for ``copies`` below 1, a negative ``jitter`` or an
    unknown ``opacity`` rule."""
    from causalsplat.io import read_gaussian_ply, write_ply

    # every argument checked before anything is written
    check_fields(
        "densify_folder",
        {"copies": copies, "jitter": jitter, "opacity": opacity},
        {"copies": Interval(1, integer=True), "jitter": Interval(0), "opacity": OPACITY_RULES},
        ValueError,
    )
    shutil.copytree(src, dst)
    scene = read_gaussian_ply(dst / "point_cloud.ply").scene
    means, origin = densify_centres(
        scene.means, np.exp(scene.log_scales.astype(np.float64)), copies, jitter, seed
    )
    logits = scene.opacity_logits
    if opacity == "kept":
        logits = split_opacity_logits(logits, copies).astype(scene.opacity_logits.dtype)
    dense = dataclasses.replace(
        scene,
        means=means.astype(np.float32),
        quats=scene.quats[origin],
        log_scales=scene.log_scales[origin],
        opacity_logits=logits[origin],
        sh=scene.sh[origin],
    )
    write_ply(dst / "point_cloud.ply", dense)
    gt = dst / "gt" / "gt_labels.npy"
    if gt.exists():
        np.save(gt, np.load(gt)[origin])
    return dst
