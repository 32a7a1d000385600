"""Compiled tile binning and compositing (the numba path's steps 2 and 3).

``tile_counts`` / ``tile_fill`` give every screen tile the depth-ordered list of the
Gaussians whose pixel extent touches it, as the numpy path's binning does.
``composite_tiles`` (a range of tiles; the caller runs ranges on several threads)
composites a tile row by row: the row's Gaussians front to back, each over the pixels of its extent,
so that every pixel meets its Gaussians in depth order and gets the 3DGS rules of the
float64 reference:

    alpha = min(alpha_max, opacity * exp(power)); skipped if alpha < alpha_min
    stop before the Gaussian that would bring the transmittance below transmittance_min
    weight = alpha * T; T *= 1 - alpha; stop after max_contributors drawn

in float64. A pixel's result depends on nothing else, so not on the thread count. It
runs in one of three modes (``COUNT``, ``FINAL``, ``SCRATCH``, see
:func:`composite_tiles`); ``gather_rows`` moves a ``SCRATCH`` result into CSR order.
"""

from __future__ import annotations

import math

import numpy as np

from causalsplat.render._jit import jit
from causalsplat.render._kernel_project import (
    CA,
    CB,
    CC,
    DECAY,
    MX,
    MY,
    N_PARAMS,
    OPACITY,
    PMIN,
    REACH,
    SHIFT,
    SQUEEZE,
)

#: A Gaussian's exp along a pixel row is stepped by two products per pixel (see
#: :func:`_composite_row`) when its x-curvature ``CA`` (1/px²) is at most this, its row
#: range spans more than STEP_MIN_PIXELS, and its PMIN exceeds STEP_MIN_POWER: then no
#: factor over- or underflows, and the at most ``tile`` steps cost a few ulps.
STEP_MAX_CA = 1.0
STEP_MIN_PIXELS = 3
STEP_MIN_POWER = -600.0

#: ``composite_tiles`` modes.
COUNT, FINAL, SCRATCH = 0, 1, 2
#: Working arrays of one ``composite_tiles`` call (see :func:`make_room`).
Room = tuple[
    np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray
]


@jit()
def tile_counts(
    order: np.ndarray,
    bbox: np.ndarray,
    image: np.ndarray,
    cap: int,
    starts: np.ndarray,
    bound: np.ndarray,
) -> None:
    """Per tile ``t``: ``starts[t + 1]`` = number of Gaussians whose pixel extent touches
    it; ``bound[t + 1]`` = an upper bound of its (pixel, Gaussian) weights: the pixels of
    those extents inside the tile, at most ``cap`` per pixel.

    ``image`` is (width, height, tile width, tile height, tiles_x); ``order`` the visible
    Gaussians.
    """
    width, height, tw, th, tiles_x = image[0], image[1], image[2], image[3], image[4]
    for r in range(order.shape[0]):
        g = order[r]
        x0, x1, y0, y1 = bbox[g, 0], bbox[g, 1], bbox[g, 2], bbox[g, 3]
        for ty in range(y0 // th, (y1 - 1) // th + 1):
            rows = min(y1, (ty + 1) * th) - max(y0, ty * th)
            for tx in range(x0 // tw, (x1 - 1) // tw + 1):
                cols = min(x1, (tx + 1) * tw) - max(x0, tx * tw)
                starts[ty * tiles_x + tx + 1] += 1
                bound[ty * tiles_x + tx + 1] += rows * cols
    for t in range(starts.shape[0] - 1):
        tx, ty = t % tiles_x, t // tiles_x
        pixels = (min(width, (tx + 1) * tw) - tx * tw) * (min(height, (ty + 1) * th) - ty * th)
        bound[t + 1] = min(bound[t + 1], pixels * cap)


@jit()
def tile_fill(
    order: np.ndarray, bbox: np.ndarray, image: np.ndarray, starts: np.ndarray, lists: np.ndarray
) -> None:
    """Scene indices of each tile's Gaussians at ``lists[starts[t]:starts[t + 1]]``, front
    to back (``order`` is front to back; ``starts`` the cumulative counts)."""
    tw, th, tiles_x = image[2], image[3], image[4]
    cursor = starts[:-1].copy()
    for r in range(order.shape[0]):
        g = order[r]
        for ty in range(bbox[g, 2] // th, (bbox[g, 3] - 1) // th + 1):
            for tx in range(bbox[g, 0] // tw, (bbox[g, 1] - 1) // tw + 1):
                t = ty * tiles_x + tx
                lists[cursor[t]] = g
                cursor[t] += 1


@jit()
def _gather_tile(
    s: int, e: int, lists: np.ndarray, params: np.ndarray, bbox: np.ndarray,
    local_params: np.ndarray, local_ints: np.ndarray,
) -> None:  # fmt: skip
    """Copy the parameters of the tile's Gaussians ``lists[s:e]`` to ``local_params`` and
    their pixel extent widened by 1 px and scene index, ``(x0 - 1, x1 + 1, y0 - 1, y1 + 1,
    g)``, to ``local_ints``. Outside its widened extent a Gaussian cannot reach
    ``alpha_min``: the widening keeps rounding at the edge from mattering, and inside it
    the exact test alone decides."""
    for j in range(e - s):
        g = lists[s + j]
        for k in range(N_PARAMS):
            local_params[j, k] = params[g, k]
        local_ints[j, 0], local_ints[j, 1] = bbox[g, 0] - 1, bbox[g, 1] + 1
        local_ints[j, 2], local_ints[j, 3] = bbox[g, 2] - 1, bbox[g, 3] + 1
        local_ints[j, 4] = g


@jit()
def _row_members(py: int, n: int, local_ints: np.ndarray, members: np.ndarray) -> int:
    """Positions (front to back) of the tile's ``n`` Gaussians whose widened extent holds
    pixel row ``py``, in ``members``; their number. Branch-free: every position is written,
    only the members advance the count."""
    m = 0
    for j in range(n):
        members[m] = j
        m += (local_ints[j, 2] <= py) & (py < local_ints[j, 3])
    return m


@jit()
def _chord(py: int, x0: int, x1: int, lp: np.ndarray, j: int) -> tuple[int, int]:
    """Pixels of ``x0 .. x1 - 1`` on row ``py`` where Gaussian ``j`` can reach
    ``alpha_min``: its chord, widened by 1 px and by 1e-6 of its half-width (which covers
    the rounding of the chord), clipped to the range."""
    dy = (py + 0.5) - lp[j, MY]
    centre = lp[j, MX] + lp[j, SHIFT] * dy
    half = math.sqrt(max(lp[j, REACH] - dy * dy, 0.0) * lp[j, SQUEEZE])
    widen = 1.0 + 1e-6 * math.sqrt(lp[j, REACH] * lp[j, SQUEEZE])
    lo = math.ceil(min(max(centre - half - widen - 0.5, x0 - 1.0), x1 + 1.0))
    hi = math.floor(min(max(centre + half + widen - 0.5, x0 - 1.0), x1 + 1.0)) + 1
    return max(int(lo), x0), min(int(hi), x1)


@jit()
def _composite_row(
    py: int, x0: int, x1: int, m: int, members: np.ndarray, lp: np.ndarray, li: np.ndarray,
    rules: np.ndarray, cap: int, state: tuple[np.ndarray, np.ndarray, np.ndarray],
    row_index: np.ndarray, row_weight: np.ndarray, write: bool,
) -> None:  # fmt: skip
    """Composite pixels ``x0 .. x1 - 1`` of row ``py`` over its ``m`` members.

    Gaussian by Gaussian, front to back, each over the pixels of its chord only; pixel
    ``px``'s transmittance, count and done flag are ``state[.][px - x0]``, and with
    ``write`` its weights go to ``row_index[px - x0]`` / ``row_weight[px - x0]``. A pixel
    meets its Gaussians in the order a per-pixel walk would, so the decisions are the
    same; the row stops when all its pixels are done.

    ``exp(power)`` along the row: ``power(dx + 1) = power(dx) + s(dx)`` with
    ``s(dx) = -ca dx - ca / 2 - cb dy`` and ``s(dx + 1) = s(dx) - ca``, so for a Gaussian
    that is wide enough (``STEP_*``) it is stepped by two products per pixel from two
    ``exp`` and ``DECAY = exp(-ca)``; otherwise each pixel has its own ``exp``.
    """
    alpha_min, alpha_max, t_min = rules[0], rules[1], rules[2]
    trans, drawn, done = state
    for q in range(x1 - x0):
        trans[q], drawn[q], done[q] = 1.0, 0, False
    active = x1 - x0
    for k in range(m):
        j = members[k]
        lo, hi = _chord(py, x0, x1, lp, j)
        while lo < hi and done[lo - x0]:  # skip the finished pixels at its start
            lo += 1
        if lo >= hi:
            continue
        g, opacity, pmin = li[j, 4], lp[j, OPACITY], lp[j, PMIN]
        mx, ca, cb, cc = lp[j, MX], lp[j, CA], lp[j, CB], lp[j, CC]
        dy = (py + 0.5) - lp[j, MY]
        step = ca <= STEP_MAX_CA and hi - lo > STEP_MIN_PIXELS and pmin > STEP_MIN_POWER
        if step:
            dx = (lo + 0.5) - mx
            gauss = math.exp(-0.5 * (ca * dx * dx + cc * dy * dy) - cb * dx * dy)
            factor = math.exp(-ca * dx - 0.5 * ca - cb * dy)
            ratio = lp[j, DECAY]
        for px in range(lo, hi):
            q = px - x0
            if step:
                here = gauss
                gauss *= factor
                factor *= ratio
                if done[q]:
                    continue
            else:
                if done[q]:
                    continue
                dx = (px + 0.5) - mx
                power = -0.5 * (ca * dx * dx + cc * dy * dy) - cb * dx * dy
                if power < pmin:
                    continue
                here = math.exp(power)
            alpha = min(alpha_max, opacity * min(here, 1.0))
            if alpha < alpha_min:
                continue
            after = trans[q] * (1.0 - alpha)
            if after < t_min:
                done[q] = True
                active -= 1
                continue
            if write:
                row_index[q, drawn[q]] = g
                row_weight[q, drawn[q]] = alpha * trans[q]
            trans[q] = after
            drawn[q] += 1
            if drawn[q] >= cap:
                done[q] = True
                active -= 1
        if active == 0:
            break


@jit()
def composite_tiles(
    starts: np.ndarray, lists: np.ndarray, params: np.ndarray, bbox: np.ndarray,
    image: np.ndarray, rules: np.ndarray, cap: int, room: Room, mode: int,
    counts: np.ndarray, offsets: np.ndarray, region: np.ndarray, out_index: np.ndarray,
    out_weight: np.ndarray, overflow: np.ndarray, first: int, last: int,
) -> None:  # fmt: skip
    """Composite every pixel of tiles ``first .. last - 1``.

    Modes: ``COUNT`` sets ``counts[pixel]``; ``FINAL`` writes the ``counts[pixel]`` weights
    of each pixel at ``offsets[pixel]`` (the CSR row pointers); ``SCRATCH`` does both at
    once, writing tile ``t``'s weights, pixel after pixel, from ``region[t]`` on, and sets
    ``counts``, ``offsets`` (where each pixel's weights start) and ``overflow[t] = 1``
    (nothing past ``region[t + 1]`` is written) if the region was too small.

    ``image``: (width, height, tile width, tile height, tiles_x); ``rules``: (alpha_min,
    alpha_max, transmittance_min); ``room``: this call's working arrays (see
    :func:`make_room`).
    """
    width, height, tw, th, tiles_x = image[0], image[1], image[2], image[3], image[4]
    lp, li, mine, trans, drawn, done, my_index, my_weight = room
    state = (trans, drawn, done)
    for t in range(first, last):
        s, e = starts[t], starts[t + 1]
        if s == e:
            continue
        _gather_tile(s, e, lists, params, bbox, lp, li)
        cursor = region[t] if mode == SCRATCH else 0
        x0, y0 = (t % tiles_x) * tw, (t // tiles_x) * th
        x1 = min(x0 + tw, width)
        for py in range(y0, min(y0 + th, height)):
            m = _row_members(py, e - s, li, mine)
            _composite_row(py, x0, x1, m, mine, lp, li, rules, cap, state, my_index,
                           my_weight, mode != COUNT)  # fmt: skip
            for q in range(x1 - x0):
                pix = py * width + x0 + q
                n = state[1][q]
                if mode == FINAL:
                    n = min(n, counts[pix])
                    base = offsets[pix]
                else:
                    counts[pix] = n
                    base = cursor
                if mode == SCRATCH:
                    offsets[pix] = cursor
                    cursor += n
                    if cursor > region[t + 1]:
                        overflow[t] = 1
                        continue
                if mode != COUNT:
                    for k in range(n):
                        out_index[base + k] = my_index[q, k]
                        out_weight[base + k] = my_weight[q, k]


def make_room(tile: int, longest: int, cap: int) -> Room:
    """Working arrays of one :func:`composite_tiles` call for tiles ``tile`` px wide whose
    lists hold at most ``longest`` Gaussians: their parameters and widened extents (see
    :func:`_gather_tile`), the members of a row (+ 1: the branch-free fill writes one past
    them); per pixel of a row its transmittance, count, done flag and weights (at most
    ``min(longest, cap)``)."""
    per_pixel = min(longest, cap)
    return (
        np.empty((longest, N_PARAMS)),
        np.empty((longest, 5), dtype=np.int64),
        np.empty(longest + 1, dtype=np.int64),
        np.empty(tile),
        np.empty(tile, dtype=np.int64),
        np.empty(tile, dtype=np.bool_),
        np.empty((tile, per_pixel), dtype=np.int32),
        np.empty((tile, per_pixel), dtype=np.float32),
    )


@jit()
def gather_rows(
    image: np.ndarray,
    offsets: np.ndarray,
    indptr: np.ndarray,
    scratch_index: np.ndarray,
    scratch_weight: np.ndarray,
    out_index: np.ndarray,
    out_weight: np.ndarray,
    first_row: int,
    last_row: int,
) -> None:
    """Move pixel rows ``first_row .. last_row - 1`` of a ``SCRATCH`` result into CSR
    order. The pixels of one tile on one pixel row are consecutive rows of the CSR and
    consecutive in their tile's region, so each such run moves as one block from
    ``offsets[first pixel]`` to ``indptr[first pixel]``."""
    width, tw, tiles_x = image[0], image[2], image[4]
    for py in range(first_row, last_row):
        for tx in range(tiles_x):
            first = py * width + tx * tw
            last = py * width + min((tx + 1) * tw, width)
            src, dst = offsets[first], indptr[first]
            size = indptr[last] - dst
            out_index[dst : dst + size] = scratch_index[src : src + size]
            out_weight[dst : dst + size] = scratch_weight[src : src + size]
