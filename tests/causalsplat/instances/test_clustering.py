"""The instance stage clusters mask features with the ``hdbscan`` package."""

from __future__ import annotations

import dataclasses
import subprocess
import sys

import numpy as np
import pytest

from causalsplat.instances import InstanceConfig
from causalsplat.instances.assign import cluster_masks

hdbscan = pytest.importorskip("hdbscan")


def _partition(labels: np.ndarray) -> tuple[list[tuple[int, ...]], tuple[int, ...]]:
    groups: dict[int, list[int]] = {}
    for i, c in enumerate(labels.tolist()):
        if c >= 0:
            groups.setdefault(c, []).append(i)
    return sorted(tuple(g) for g in groups.values()), tuple(np.flatnonzero(labels < 0))


def _unit_blobs(seed: int, n: int = 120, dim: int = 16, k: int = 5) -> np.ndarray:
    rng = np.random.default_rng(seed)
    centres = rng.normal(size=(k, dim))
    x = centres[rng.integers(0, k, n)] + rng.normal(size=(n, dim)) * 0.15
    return x / np.linalg.norm(x, axis=1, keepdims=True)


class _Spy:
    """Counts the package's fits (wraps ``hdbscan.HDBSCAN``)."""

    def __init__(self) -> None:
        self.calls: list[dict[str, object]] = []

    def __call__(self, **kw: object) -> object:
        self.calls.append(kw)
        return _REAL(**kw)


_REAL = hdbscan.HDBSCAN


def test_clusters_are_the_packages(monkeypatch: pytest.MonkeyPatch) -> None:
    spy = _Spy()
    monkeypatch.setattr(hdbscan, "HDBSCAN", spy)
    config = InstanceConfig()
    for seed in range(6):
        x = _unit_blobs(seed)
        ours = cluster_masks(x, config)
        theirs = _REAL(
            min_cluster_size=config.min_cluster_size,
            min_samples=config.min_samples,
            cluster_selection_method=config.selection,
            cluster_selection_epsilon=config.selection_epsilon,
            approx_min_span_tree=False,
        ).fit(x)
        assert _partition(ours) == _partition(np.asarray(theirs.labels_))
        assert ours.dtype == np.int64 and ours.max() >= 1
    assert len(spy.calls) == 6
    assert {c["approx_min_span_tree"] for c in spy.calls} == {False}


def test_options_reach_the_package(monkeypatch: pytest.MonkeyPatch) -> None:
    spy = _Spy()
    monkeypatch.setattr(hdbscan, "HDBSCAN", spy)
    config = InstanceConfig(
        min_cluster_size=4, min_samples=2, selection="leaf", selection_epsilon=0.1
    )
    cluster_masks(_unit_blobs(1), config)
    (call,) = spy.calls
    assert call["min_cluster_size"] == 4 and call["min_samples"] == 2
    assert call["cluster_selection_method"] == "leaf"
    assert call["cluster_selection_epsilon"] == 0.1
    # min_samples=None is HDBSCAN's own default, min_cluster_size
    spy.calls.clear()
    cluster_masks(_unit_blobs(1), dataclasses.replace(config, min_samples=None))
    assert spy.calls[0]["min_samples"] == 4


@pytest.mark.parametrize(
    "name, x",
    [
        ("identical points", np.ones((10, 3))),
        ("each point four times", np.repeat(np.random.default_rng(1).normal(size=(6, 4)), 4, 0)),
        ("three points", np.random.default_rng(3).normal(size=(3, 2))),
        ("evenly spaced line", np.arange(12.0)[:, None]),
        ("fewer points than min_samples", np.random.default_rng(4).normal(size=(4, 2))),
    ],
)
def test_degenerate_mask_sets(name: str, x: np.ndarray) -> None:
    """No exception; one object seen many times is one cluster, not noise."""
    config = InstanceConfig(min_cluster_size=3, min_samples=6)
    labels = cluster_masks(x, config)
    assert labels.shape == (x.shape[0],) and labels.dtype == np.int64
    if name == "identical points":
        assert set(labels.tolist()) == {0}


def test_too_few_masks_are_noise() -> None:
    assert cluster_masks(np.zeros((2, 4)), InstanceConfig(min_cluster_size=3)).tolist() == [-1, -1]
    assert cluster_masks(np.zeros((0, 4)), InstanceConfig()).tolist() == []


def test_the_package_is_imported_by_the_stage_not_by_the_library() -> None:
    code = (
        "import sys, numpy as np\n"
        "import causalsplat, causalsplat.instances.assign as a\n"
        "before = 'hdbscan' in sys.modules\n"
        "from causalsplat.instances import InstanceConfig\n"
        "a.cluster_masks(np.random.default_rng(0).normal(size=(60, 4)), InstanceConfig())\n"
        "print(before, 'hdbscan' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "True"]
