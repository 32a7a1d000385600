"""Gaussians sampled on the visible faces of each entity's box.

Each entity gets ``max(min_gaussians_per_object, f * w_kind * area)`` Gaussians, where
``area`` is the area of its sampled faces, ``w_kind`` the density weight of its kind
(structure, furniture, small) and ``f`` the one factor that makes the total meet the budget.
Faces sampled: the floor's top, each wall's inner face, and every face of the other boxes
except the bottom. Points are stratified on a jittered grid per face; each Gaussian is a
flat disc on its face, as trained 3DGS makes them: standard deviation ``gaussian_scale``
times the grid spacing in the face's plane and ``normal_scale`` times that along the normal,
and has the entity's colour, shaded per face (top 1.0, x faces 0.85, y faces 0.75), plus a
little noise.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from causalsplat.io.types import GaussianScene
from causalsplat.synth._layout import RoomLayout, SynthObject
from causalsplat.synth.config import SynthConfig
from causalsplat.synth.vocab import Kind

Face = tuple[int, int]  # (axis, sign): the face of the box at lo (sign -1) or hi (+1) of axis
_SHADE = {0: 0.85, 1: 0.75, 2: 1.0}
_MAX_SIGMA_M = 0.15


@dataclass(frozen=True, slots=True)
class SampledGaussians:
    """The Gaussians of a synthetic room.

    Attributes:
        scene: the Gaussian scene (DC-only SH), world frame, metres.
        labels: (N,) int32 GT entity id of each Gaussian.
    """

    scene: GaussianScene
    labels: np.ndarray


def _faces(obj: SynthObject, layout: RoomLayout) -> list[Face]:
    if obj.category == "floor":
        return [(2, 1)]
    if obj.category == "wall":
        axis = int(np.argmin(obj.size))
        mid = 0.5 * np.asarray(layout.room_size)
        return [(axis, 1 if obj.center[axis] < mid[axis] else -1)]
    return [(a, s) for a in range(3) for s in (-1, 1) if (a, s) != (2, -1)]


def _face_area(obj: SynthObject, face: Face) -> float:
    dims = [obj.size[i] for i in range(3) if i != face[0]]
    return float(dims[0] * dims[1])


def _budget(areas: np.ndarray, weights: np.ndarray, total: int, minimum: int) -> np.ndarray:
    """Per-entity counts ``max(minimum, round(f * w * a))`` summing to about ``total``."""

    def counts(f: float) -> np.ndarray:
        out: np.ndarray = np.maximum(minimum, np.rint(f * weights * areas)).astype(np.int64)
        return out

    lo, hi = 0.0, 1.0
    while counts(hi).sum() < total and hi < 1e12:
        hi *= 2.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if counts(mid).sum() < total else (lo, mid)
    return counts(hi)


def _split_counts(n: int, areas: list[float]) -> list[int]:
    """Split ``n`` over faces proportionally to area (largest remainder)."""
    a = np.asarray(areas, dtype=np.float64)
    exact = n * a / a.sum()
    base = np.floor(exact).astype(np.int64)
    order = np.argsort(-(exact - base), kind="stable")
    base[order[: n - int(base.sum())]] += 1
    return [int(v) for v in base]


def _sample_face(
    obj: SynthObject, face: Face, n: int, rng: np.random.Generator
) -> tuple[np.ndarray, float]:
    """``~n`` stratified points on one face and the grid spacing (m)."""
    axis, sign = face
    u_axis, v_axis = [i for i in range(3) if i != axis]
    lo, hi = obj.lo, obj.hi
    du, dv = hi[u_axis] - lo[u_axis], hi[v_axis] - lo[v_axis]
    nu = max(1, round(np.sqrt(n * du / dv)))
    nv = max(1, round(n / nu))
    iu, iv = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    jitter = rng.random((nu * nv, 2))
    pts = np.empty((nu * nv, 3))
    pts[:, u_axis] = lo[u_axis] + (iu.reshape(-1) + jitter[:, 0]) * du / nu
    pts[:, v_axis] = lo[v_axis] + (iv.reshape(-1) + jitter[:, 1]) * dv / nv
    pts[:, axis] = hi[axis] if sign > 0 else lo[axis]
    return pts, float(np.sqrt(du * dv / (nu * nv)))


def sample_gaussians(
    layout: RoomLayout, cfg: SynthConfig, rng: np.random.Generator
) -> SampledGaussians:
    """Sample the Gaussians of every entity (module docstring); deterministic given ``rng``."""
    weight_of = dict(zip(Kind, cfg.density_weights, strict=True))
    faces = [_faces(o, layout) for o in layout.objects]
    areas = np.array([sum(_face_area(o, f) for f in fs) for o, fs in zip(layout.objects, faces)])
    weights = np.array([weight_of[o.kind] for o in layout.objects])
    counts = _budget(areas, weights, cfg.n_gaussians, cfg.min_gaussians_per_object)
    means, colors, sigmas, labels = [], [], [], []
    for obj, obj_faces, n_obj in zip(layout.objects, faces, counts, strict=True):
        split = _split_counts(int(n_obj), [_face_area(obj, f) for f in obj_faces])
        for face, n_face in zip(obj_faces, split, strict=True):
            if n_face == 0:
                continue
            pts, spacing = _sample_face(obj, face, n_face, rng)
            m = pts.shape[0]
            sigma = min(cfg.gaussian_scale * spacing, _MAX_SIGMA_M)
            rgb = np.asarray(obj.rgb) * _SHADE[face[0]]
            means.append(pts)
            colors.append(rgb + cfg.color_noise * rng.standard_normal((m, 3)))
            sig = sigma * rng.uniform(0.9, 1.1, (m, 3))
            sig[:, face[0]] *= cfg.normal_scale
            sigmas.append(sig)
            labels.append(np.full(m, obj.id, dtype=np.int32))
    scene = GaussianScene.from_points(
        np.concatenate(means),
        np.clip(np.concatenate(colors), 0.0, 1.0),
        np.concatenate(sigmas),
        opacity=cfg.opacity,
    )
    return SampledGaussians(scene=scene, labels=np.concatenate(labels))
