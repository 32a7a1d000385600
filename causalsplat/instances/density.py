"""HDBSCAN of the mask features: density-based clusters, noise, and no cluster count given.

The method (Campello, Moulavit and Sander 2013, with the cluster selection of McInnes and
Healy's ``hdbscan`` package, whose results the tests hold this to) in five steps, each a
function here:

1. core distance of a point: the Euclidean distance to its ``min_samples``-th nearest
   other point (:func:`core_distances`);
2. the minimum spanning tree of the mutual reachability distance
   ``max(d(a, b), core(a), core(b))``, by Prim's algorithm, exact, in O(n) memory
   (:func:`mutual_reachability_mst`);
3. its single-linkage hierarchy (:func:`single_linkage`);
4. the hierarchy condensed by ``min_cluster_size``: a split leaving a side smaller than
   that is points falling out of one cluster, not two clusters (:func:`condense`);
5. the flat clusters by excess of mass (``eom``) or the leaves (``leaf``), merged up to
   ``epsilon`` (``cluster_selection_epsilon``), and each point's label
   (:func:`select_clusters`).

It replaces the ``hdbscan`` package in a build, whose import (scikit-learn, scipy.stats)
took 0.6-0.9 s of every build process and, on a thread of its own, held the interpreter
lock long enough to slow the training beside it by as much. A mask set has thousands of
points at most (one per usable mask), where the exact O(n^2) tree takes milliseconds to a
few seconds; the package's tree is approximate by default, so on rare ties the two may
choose different edges of equal weight.

>>> x = np.array([[0.0], [0.1], [0.2], [5.0], [5.1], [5.2], [20.0]])
>>> hdbscan_labels(x, min_cluster_size=3, min_samples=1).tolist()
[0, 0, 0, 1, 1, 1, -1]
"""

from __future__ import annotations

import math

import numpy as np

INF = math.inf


def hdbscan_labels(
    x: np.ndarray,
    *,
    min_cluster_size: int,
    min_samples: int | None = None,
    selection: str = "eom",
    epsilon: float = 0.0,
    allow_single_cluster: bool = False,
) -> np.ndarray:
    """(n,) int64 cluster of each row of the (n, d) ``x``, numbered from 0; -1 is noise.

    ``min_samples`` defaults to ``min_cluster_size`` and is capped at ``n - 1``.
    """
    x = np.ascontiguousarray(x, dtype=np.float64)
    n = x.shape[0]
    if min_cluster_size < 2:
        raise ValueError(f"min_cluster_size must be in [2, inf), got {min_cluster_size}")
    if selection not in ("eom", "leaf"):
        raise ValueError(f"selection must be one of 'eom', 'leaf', got {selection!r}")
    if n < 2:
        return np.full(n, -1, dtype=np.int64)
    k = min(n - 1, min_cluster_size if min_samples is None else min_samples)
    core = core_distances(x, max(k, 1))
    hierarchy = single_linkage(*mutual_reachability_mst(x, core), n)
    tree = condense(hierarchy, min_cluster_size)
    return select_clusters(tree, n, selection, epsilon, allow_single_cluster)


def core_distances(x: np.ndarray, k: int) -> np.ndarray:
    """(n,) distance from each row of ``x`` to its ``k``-th nearest other row."""
    from scipy.spatial import cKDTree

    distances, _ = cKDTree(x).query(x, k=k + 1)
    return np.ascontiguousarray(distances[:, -1], dtype=np.float64)


def mutual_reachability_mst(
    x: np.ndarray, core: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The n - 1 edges (from, to, weight) of the minimum spanning tree of the mutual
    reachability distance, in the order Prim's algorithm from point 0 adds them."""
    n = x.shape[0]
    start, end, weight = (np.empty(n - 1, dtype=np.int64), np.empty(n - 1, dtype=np.int64),
                          np.empty(n - 1))  # fmt: skip
    from causalsplat.render._backend import numba_available

    if numba_available():
        from causalsplat.instances._kernel_mst import prim_mst

        prim_mst(x, core, start, end, weight)
        return start, end, weight
    in_tree = np.zeros(n, dtype=bool)
    best = np.full(n, INF)
    link = np.zeros(n, dtype=np.int64)
    current = 0
    for step in range(n - 1):
        in_tree[current] = True
        d = np.sqrt(((x - x[current]) ** 2).sum(axis=1))
        reach = np.maximum(np.maximum(d, core[current]), core)
        closer = (reach < best) & ~in_tree
        best[closer] = reach[closer]
        link[closer] = current
        candidates = np.where(in_tree, INF, best)
        chosen = int(np.argmin(candidates))
        start[step], end[step], weight[step] = link[chosen], chosen, best[chosen]
        current = chosen
    return start, end, weight


def single_linkage(start: np.ndarray, end: np.ndarray, weight: np.ndarray, n: int) -> np.ndarray:
    """(n - 1, 4) merges ``[left, right, distance, size]`` of the tree's edges taken by
    increasing weight (stable); merge ``i`` makes node ``n + i`` (scipy's linkage layout)."""
    order = np.argsort(weight, kind="stable")
    parent = list(range(2 * n - 1))
    size = [1] * n + [0] * (n - 1)
    out = np.empty((n - 1, 4))

    def find(node: int) -> int:
        root = node
        while parent[root] != root:
            root = parent[root]
        while parent[node] != root:  # path compression
            parent[node], node = root, parent[node]
        return root

    for i, e in enumerate(order.tolist()):
        a, b = find(int(start[e])), find(int(end[e]))
        merged = n + i
        size[merged] = size[a] + size[b]
        out[i] = (a, b, weight[e], size[merged])
        parent[a] = parent[b] = merged
    return out


def _bfs(hierarchy: np.ndarray, root: int, n: int) -> list[int]:
    """Nodes under ``root`` (itself first), level by level, left before right."""
    result: list[int] = []
    level = [root]
    while level:
        result.extend(level)
        level = [int(c) for node in level if node >= n for c in hierarchy[node - n, :2]]
    return result


def condense(hierarchy: np.ndarray, min_cluster_size: int) -> np.ndarray:
    """The condensed tree: (rows, 4) float64 ``[parent, child, lambda, child_size]``.

    Clusters are numbered from ``n`` (the root) in the order they appear walking the
    hierarchy breadth first; a child below ``n`` is a point leaving its cluster at
    ``lambda = 1 / distance``.
    """
    n = hierarchy.shape[0] + 1
    root = 2 * n - 2
    relabel = {root: n}
    next_label = n + 1
    ignore = np.zeros(2 * n - 1, dtype=bool)
    rows: list[tuple[int, int, float, int]] = []

    def count(node: int) -> int:
        return int(hierarchy[node - n, 3]) if node >= n else 1

    def fall_out(side: int, label: int, lam: float) -> None:
        for sub in _bfs(hierarchy, side, n):
            if sub < n:
                rows.append((label, sub, lam, 1))
            ignore[sub] = True

    for node in _bfs(hierarchy, root, n):
        if node < n or ignore[node]:
            continue
        left, right = int(hierarchy[node - n, 0]), int(hierarchy[node - n, 1])
        distance = float(hierarchy[node - n, 2])
        lam = 1.0 / distance if distance > 0.0 else INF
        big_left, big_right = count(left) >= min_cluster_size, count(right) >= min_cluster_size
        label = relabel[node]
        if big_left and big_right:
            for side in (left, right):
                relabel[side] = next_label
                rows.append((label, next_label, lam, count(side)))
                next_label += 1
        elif not big_left and not big_right:
            fall_out(left, label, lam)
            fall_out(right, label, lam)
        elif not big_left:
            relabel[right] = label
            fall_out(left, label, lam)
        else:
            relabel[left] = label
            fall_out(right, label, lam)
    return np.array(rows, dtype=np.float64).reshape(-1, 4)


def stabilities(tree: np.ndarray, n: int) -> dict[int, float]:
    """Each cluster's stability: ``sum (lambda - lambda_birth) * size`` over its rows."""
    parents, children = tree[:, 0].astype(np.int64), tree[:, 1].astype(np.int64)
    lambdas, sizes = tree[:, 2], tree[:, 3]
    birth: dict[int, float] = {n: 0.0}
    for child, lam in zip(children.tolist(), lambdas.tolist()):
        if child >= n:
            birth[child] = min(birth.get(child, INF), lam)
    out = dict.fromkeys(range(n, int(parents.max()) + 1), 0.0)
    for parent, lam, size in zip(parents.tolist(), lambdas.tolist(), sizes.tolist()):
        out[parent] += (lam - birth[parent]) * size
    return out


def select_clusters(
    tree: np.ndarray, n: int, selection: str, epsilon: float, allow_single_cluster: bool
) -> np.ndarray:
    """The flat clustering of a condensed tree (module docstring, step 5)."""
    labels = np.full(n, -1, dtype=np.int64)
    if tree.shape[0] == 0:
        return labels
    stability = stabilities(tree, n)
    nodes = sorted(stability, reverse=True)  # children before parents
    if not allow_single_cluster:
        nodes = nodes[:-1]  # the root
    cluster_rows = tree[tree[:, 3] > 1]
    children: dict[int, list[int]] = {}
    parent_of: dict[int, tuple[int, float]] = {}
    for p, c, lam in cluster_rows[:, :3].tolist():
        children.setdefault(int(p), []).append(int(c))
        parent_of[int(c)] = (int(p), lam)
    root = n
    is_cluster = dict.fromkeys(nodes, True)
    if selection == "eom":
        for node in nodes:
            below = np.float32(0.0)  # the package sums the children in single precision
            for child in children.get(node, []):
                below = np.float32(float(below) + stability[child])
            if float(below) > stability[node]:
                is_cluster[node] = False
                stability[node] = float(below)
            else:
                for sub in _tree_bfs(children, node)[1:]:
                    is_cluster[sub] = False
        if epsilon != 0.0 and cluster_rows.shape[0] > 0:
            chosen = [c for c in is_cluster if is_cluster[c]]
            if len(chosen) == 1 and chosen[0] == root:
                kept = set(chosen) if allow_single_cluster else set()
            else:
                kept = _epsilon_merge(set(chosen), parent_of, children, epsilon,
                                      allow_single_cluster, root)  # fmt: skip
            is_cluster = {c: c in kept for c in is_cluster}
    else:
        leaves = set(_leaves(children, root)) if cluster_rows.shape[0] > 0 else set()
        if not leaves:
            is_cluster = dict.fromkeys(is_cluster, False)
            is_cluster[root] = True
        kept = (_epsilon_merge(leaves, parent_of, children, epsilon, allow_single_cluster, root)
                if epsilon != 0.0 else leaves)  # fmt: skip
        is_cluster = {c: c in kept for c in is_cluster}
    clusters = {c for c, chosen in is_cluster.items() if chosen}
    number = {c: i for i, c in enumerate(sorted(clusters))}
    return _label_points(tree, n, clusters, number, allow_single_cluster, epsilon)


def _tree_bfs(children: dict[int, list[int]], top: int) -> list[int]:
    result: list[int] = []
    level = [top]
    while level:
        result.extend(level)
        level = [c for node in level for c in children.get(node, [])]
    return result


def _leaves(children: dict[int, list[int]], top: int) -> list[int]:
    leaves, stack = [], [top]
    while stack:
        node = stack.pop()
        if node in children:
            stack.extend(children[node])
        else:
            leaves.append(node)
    return leaves


def _epsilon_merge(
    chosen: set[int],
    parent_of: dict[int, tuple[int, float]],
    children: dict[int, list[int]],
    epsilon: float,
    allow_single_cluster: bool,
    root: int,
) -> set[int]:
    """Clusters born closer than ``epsilon`` give way to the first ancestor born farther
    (the root only when a single cluster is allowed). Visits ``chosen`` in set order, as
    the package does: a cluster already merged into an ancestor is skipped."""
    kept: list[int] = []
    merged: set[int] = set()
    for leaf in chosen:
        if 1.0 / parent_of[leaf][1] >= epsilon:
            kept.append(leaf)
            continue
        if leaf in merged:
            continue
        node = leaf
        while True:
            parent = parent_of[node][0]
            if parent == root:
                target = parent if allow_single_cluster else node
                break
            if 1.0 / parent_of[parent][1] > epsilon:
                target = parent
                break
            node = parent
        kept.append(target)
        merged.update(_tree_bfs(children, target)[1:])
    return set(kept)


def _label_points(
    tree: np.ndarray,
    n: int,
    clusters: set[int],
    number: dict[int, int],
    allow_single_cluster: bool,
    epsilon: float,
) -> np.ndarray:
    """Each point's cluster: the first selected cluster above it in the tree; points that
    reach the root are noise unless the root is the one cluster allowed."""
    parent: dict[int, int] = {}
    fell_at = np.zeros(n)
    root_max = 0.0
    for p, c, lam, _ in tree.tolist():
        parent[int(c)] = int(p)
        if c < n:
            fell_at[int(c)] = lam
        if int(p) == n:
            root_max = max(root_max, lam)
    labels = np.full(n, -1, dtype=np.int64)
    single = len(clusters) == 1 and allow_single_cluster and n in number
    for point in range(n):
        node = parent[point]
        while node not in clusters and node != n:
            node = parent[node]
        if node != n:
            labels[point] = number[node]
        elif single:
            floor = 1.0 / epsilon if epsilon != 0.0 else root_max
            if fell_at[point] >= floor:
                labels[point] = number[n]
    return labels


__all__ = [
    "condense",
    "core_distances",
    "hdbscan_labels",
    "mutual_reachability_mst",
    "select_clusters",
    "single_linkage",
    "stabilities",
]
