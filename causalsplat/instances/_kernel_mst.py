"""Prim's minimum spanning tree under mutual reachability, compiled (imports numba; lazily).

:func:`causalsplat.instances.density.mutual_reachability_mst` runs it where numba imports,
else the same loop with one numpy pass over the points per step. Distances are computed
on the fly, so memory is O(n) for n points and time O(n^2 d).
"""

from __future__ import annotations

import numpy as np

from causalsplat.render._jit import jit


@jit()
def prim_mst(  # pragma: no cover - compiled
    x: np.ndarray,
    core: np.ndarray,
    out_from: np.ndarray,
    out_to: np.ndarray,
    out_weight: np.ndarray,
) -> None:
    """Edges ``(out_from[i], out_to[i], out_weight[i])`` of the tree, in the order Prim's
    algorithm adds them from point 0; a tie goes to the lowest index."""
    n, dim = x.shape
    in_tree = np.zeros(n, dtype=np.bool_)
    best = np.full(n, np.inf)
    link = np.zeros(n, dtype=np.int64)
    current = 0
    for step in range(n - 1):
        in_tree[current] = True
        chosen = -1
        chosen_weight = np.inf
        for j in range(n):
            if in_tree[j]:
                continue
            total = 0.0
            for c in range(dim):
                diff = x[current, c] - x[j, c]
                total += diff * diff
            weight = max(np.sqrt(total), core[current], core[j])
            if weight < best[j]:
                best[j] = weight
                link[j] = current
            if chosen < 0 or best[j] < chosen_weight:
                chosen = j
                chosen_weight = best[j]
        out_from[step] = link[chosen]
        out_to[step] = chosen
        out_weight[step] = chosen_weight
        current = chosen


__all__ = ["prim_mst"]
