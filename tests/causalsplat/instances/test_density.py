"""HDBSCAN written here, held to the ``hdbscan`` package (a test dependency only).

With ``min_samples=1`` (the build's default) the mutual reachability distance is the
Euclidean one, its minimum spanning tree is unique for points in general position, and
the clusters must be the package's exactly. With more neighbours many edges weigh the
same (a core distance), any minimum spanning tree is right, and the package's own two
exact-tree algorithms disagree on such ties; there the test holds the tree's weights
(the same for every minimum spanning tree) to the package's exact one.
"""

from __future__ import annotations

import numpy as np
import pytest

from causalsplat.instances.density import (
    core_distances,
    hdbscan_labels,
    mutual_reachability_mst,
)

hdbscan = pytest.importorskip("hdbscan")


def _partition(labels: np.ndarray) -> tuple[list[tuple[int, ...]], tuple[int, ...]]:
    groups: dict[int, list[int]] = {}
    for i, c in enumerate(labels.tolist()):
        if c >= 0:
            groups.setdefault(c, []).append(i)
    return sorted(tuple(g) for g in groups.values()), tuple(np.flatnonzero(labels < 0))


def _blobs(rng: np.random.Generator, n: int, dim: int, k: int, spread: float) -> np.ndarray:
    centres = rng.normal(size=(k, dim)) * 3
    return centres[rng.integers(0, k, n)] + rng.normal(size=(n, dim)) * spread


def _reference(x: np.ndarray, **kw: object) -> np.ndarray:
    model = hdbscan.HDBSCAN(metric="euclidean", **kw)
    return np.asarray(model.fit(x).labels_)


@pytest.mark.parametrize("seed", range(12))
def test_one_neighbour_clusters_are_the_packages(seed: int) -> None:
    rng = np.random.default_rng(seed)
    for trial in range(10):
        n, dim = int(rng.integers(5, 300)), int(rng.integers(1, 17))
        x = _blobs(rng, n, dim, int(rng.integers(1, 6)), float(rng.uniform(0.1, 1.5)))
        if trial % 3 == 0:
            x /= np.linalg.norm(x, axis=1, keepdims=True)  # unit features, as the build's
        mcs = int(rng.integers(2, 8))
        selection = ("eom", "leaf")[trial % 2]
        epsilon = (0.0, 0.1, 0.4, 1.0)[trial % 4]
        single = trial % 5 == 0
        ours = hdbscan_labels(
            x,
            min_cluster_size=mcs,
            min_samples=1,
            selection=selection,
            epsilon=epsilon,
            allow_single_cluster=single,
        )
        theirs = _reference(
            x,
            min_cluster_size=mcs,
            min_samples=1,
            cluster_selection_method=selection,
            cluster_selection_epsilon=epsilon,
            allow_single_cluster=single,
        )
        assert _partition(ours) == _partition(theirs), (seed, trial)
        assert ours.dtype == np.int64 and ours.max() + 1 == len(set(ours.tolist()) - {-1})


@pytest.mark.parametrize(
    "name, x",
    [
        ("identical points", np.ones((10, 3))),
        ("each point four times", np.repeat(np.random.default_rng(1).normal(size=(6, 4)), 4, 0)),
        (
            "two exact piles and strays",
            np.vstack(
                [
                    np.zeros((5, 2)),
                    np.full((5, 2), 3.0),
                    np.random.default_rng(2).normal(size=(3, 2)) * 10,
                ]
            ),
        ),
        ("three points", np.random.default_rng(3).normal(size=(3, 2))),
        ("evenly spaced line", np.arange(12.0)[:, None]),
    ],
)
def test_degenerate_sets_match_the_package(name: str, x: np.ndarray) -> None:
    """Zero distances (infinite lambda), a single pile, no structure at all."""
    for single in (False, True):
        for selection in ("eom", "leaf"):
            for epsilon in (0.0, 0.5):
                kw = {"selection": selection, "epsilon": epsilon, "allow_single_cluster": single}
                ours = hdbscan_labels(x, min_cluster_size=3, min_samples=1, **kw)  # type: ignore[arg-type]
                theirs = _reference(
                    x,
                    min_cluster_size=3,
                    min_samples=1,
                    cluster_selection_method=selection,
                    cluster_selection_epsilon=epsilon,
                    allow_single_cluster=single,
                )
                assert _partition(ours) == _partition(theirs), (name, kw)


@pytest.mark.parametrize("min_samples", [2, 3, 5])
def test_spanning_tree_weights_are_the_exact_packages(min_samples: int) -> None:
    rng = np.random.default_rng(min_samples)
    for _ in range(8):
        x = _blobs(rng, int(rng.integers(10, 200)), int(rng.integers(1, 9)), 3, 0.5)
        core = core_distances(x, min_samples)
        start, end, weight = mutual_reachability_mst(x, core)
        d = np.linalg.norm(x[start] - x[end], axis=1)
        np.testing.assert_allclose(weight, np.maximum(d, np.maximum(core[start], core[end])))
        assert _connected(start, end, x.shape[0])
        model = hdbscan.HDBSCAN(
            min_cluster_size=3,
            min_samples=min_samples,
            algorithm="prims_kdtree",
            gen_min_span_tree=True,
        ).fit(x)
        reference = np.sort(model.minimum_spanning_tree_._mst[:, 2])
        np.testing.assert_allclose(np.sort(weight), reference, rtol=1e-12)


def _connected(start: np.ndarray, end: np.ndarray, n: int) -> bool:
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    graph = sp.coo_matrix((np.ones(start.size), (start, end)), shape=(n, n))
    return int(connected_components(graph, directed=False)[0]) == 1


def test_numpy_and_compiled_trees_agree(monkeypatch: pytest.MonkeyPatch) -> None:
    pytest.importorskip("numba")
    from causalsplat.render import _backend

    rng = np.random.default_rng(7)
    x = _blobs(rng, 150, 6, 4, 0.7)
    core = core_distances(x, 2)
    compiled = mutual_reachability_mst(x, core)
    monkeypatch.setattr(_backend, "numba_available", lambda: False)
    plain = mutual_reachability_mst(x, core)
    for a, b in zip(compiled, plain, strict=True):
        np.testing.assert_array_equal(a, b)


def test_too_few_points_and_bad_options() -> None:
    assert hdbscan_labels(np.zeros((1, 2)), min_cluster_size=2).tolist() == [-1]
    assert hdbscan_labels(np.zeros((0, 2)), min_cluster_size=2).tolist() == []
    with pytest.raises(ValueError, match=r"min_cluster_size must be in \[2, inf\), got 1"):
        hdbscan_labels(np.zeros((4, 2)), min_cluster_size=1)
    with pytest.raises(ValueError, match="selection must be one of 'eom', 'leaf', got 'all'"):
        hdbscan_labels(np.zeros((4, 2)), min_cluster_size=2, selection="all")


def test_the_build_never_imports_the_package() -> None:
    """The instance stage runs on this module alone (the package is a test reference)."""
    import subprocess
    import sys

    code = (
        "import sys, numpy as np\n"
        "from causalsplat.instances.assign import cluster_masks\n"
        "from causalsplat.instances import InstanceConfig\n"
        "x = np.random.default_rng(0).normal(size=(60, 4))\n"
        "cluster_masks(x, InstanceConfig())\n"
        "print(sorted(m for m in ('hdbscan', 'sklearn') if m in sys.modules))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
