"""Densified scenes (tests and the scale benchmark): every Gaussian copied with a small jitter.

Real 3DGS scenes hold many overlapping near-duplicate Gaussians (densification clones and
splits them). Copying each Gaussian of a synthetic scene ``copies`` times reproduces that:
the copies are moved by ``jitter`` times the Gaussian's largest scale (normal noise), and
the first two copies stay exactly on the original (duplicates at zero distance).
"""

from __future__ import annotations

import dataclasses
import shutil
from pathlib import Path

import numpy as np


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


def densify_folder(src: Path, dst: Path, copies: int, jitter: float, seed: int = 0) -> Path:
    """Copy the scene folder ``src`` to ``dst`` with its PLY densified (module docstring)
    and its GT labels (``gt/gt_labels.npy``, when present) repeated to match."""
    from causalsplat.io import read_gaussian_ply, write_ply

    shutil.copytree(src, dst)
    scene = read_gaussian_ply(dst / "point_cloud.ply").scene
    means, origin = densify_centres(
        scene.means, np.exp(scene.log_scales.astype(np.float64)), copies, jitter, seed
    )
    dense = dataclasses.replace(
        scene,
        means=means.astype(np.float32),
        quats=scene.quats[origin],
        log_scales=scene.log_scales[origin],
        opacity_logits=scene.opacity_logits[origin],
        sh=scene.sh[origin],
    )
    write_ply(dst / "point_cloud.ply", dense)
    gt = dst / "gt" / "gt_labels.npy"
    if gt.exists():
        np.save(gt, np.load(gt)[origin])
    return dst
