"""One floor, one ceiling (``instances/structures.py``): the clusters a single structure fell
into are one entity when their masks say so; walls, unlabelled masks and the option off
keep them apart."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from causalsplat.build.config import BuildConfig, BuildConfigError
from causalsplat.field import FeatureField, FieldConfig, MaskEvidence
from causalsplat.instances import InstanceConfig, InstanceConfigError, assign_instances
from causalsplat.instances.structures import cluster_labels, structure_pairs

AXES = np.eye(3)


def test_a_cluster_takes_the_label_more_than_half_its_labelled_masks_carry() -> None:
    cluster = np.array([0, 0, 0, 1, 1, 2, 2, -1, 3])
    labels = ["floor", "Floor", "rug", "wall", "floor", None, "ceiling ", "floor", None]
    assert cluster_labels(cluster, labels, 4) == ["floor", None, "ceiling", None]


def test_only_clusters_of_one_listed_structure_pair_up() -> None:
    labels = ["floor", "wall", "floor", "wall", None, "ceiling", "ceiling"]
    got = structure_pairs(labels, ("floor", "ceiling"))
    want = np.eye(7, dtype=bool)
    for a, b in ((0, 2), (5, 6)):
        want[a, b] = want[b, a] = True
    assert (got == want).all()


def _two_halves(
    label: str,
) -> tuple[FeatureField, MaskEvidence, np.ndarray, list[str | None]]:
    """Twelve Gaussians of one surface: 0-5 seen by views 0-2, 6-11 by views 3-5, with
    features far apart (two clusters no Gaussian joins), and a chair (12-14) that views
    0-2 see too."""
    n = 15
    feats = np.zeros((n, 3), dtype=np.float32)
    feats[:6], feats[6:12], feats[12:] = AXES[0], AXES[1], AXES[2]
    rows, mask_feats, views = [], [], []
    for view in range(6):
        w = np.zeros(n)
        w[:6] = 1.0 if view < 3 else 0.0
        w[6:12] = 1.0 if view >= 3 else 0.0
        rows.append(w)
        mask_feats.append(AXES[0] if view < 3 else AXES[1])
        views.append(view)
    for view in range(3):
        w = np.zeros(n)
        w[12:] = 1.0
        rows.append(w)
        mask_feats.append(AXES[2])
        views.append(view)
    field = FeatureField(feats, np.ones(n, bool), np.ones(n, bool), (),
                         FieldConfig(feature_dim=3))  # fmt: skip
    evidence = MaskEvidence(
        view=np.array(views),
        index=np.array([0] * 6 + [1] * 3),
        pixel_weight=np.ones(9),
        features=np.array(mask_feats, dtype=np.float32),
        gaussian_weight=sp.csr_matrix(np.array(rows)),
    )
    means = np.zeros((n, 3))
    means[:, 0] = np.arange(n, dtype=float)
    return field, evidence, means, [label] * 6 + ["chair"] * 3


def _entities(label: str, config: InstanceConfig, *, labelled: bool = True) -> list[int]:
    field, evidence, means, labels = _two_halves(label)
    out = assign_instances(field, evidence, config, means=means, scales=np.full((15, 3), 0.1),
                           mask_labels=labels if labelled else None)  # fmt: skip
    return out.labels.tolist()


def test_the_two_halves_of_a_floor_are_one_entity() -> None:
    config = InstanceConfig(min_gaussians=1, propagate_sigmas=0.0)
    assert _entities("Floor", config) == [0] * 12 + [1] * 3
    # what the masks do not call a single structure stays as the features cluster it
    assert _entities("wall", config) == [0] * 6 + [1] * 6 + [2] * 3
    assert _entities("floor", config, labelled=False) == [0] * 6 + [1] * 6 + [2] * 3
    off = InstanceConfig(min_gaussians=1, propagate_sigmas=0.0, merge_structures=())
    assert _entities("floor", off) == [0] * 6 + [1] * 6 + [2] * 3
    # without the consensus merge, the structures still join
    alone = InstanceConfig(min_gaussians=1, propagate_sigmas=0.0, merge_overlap=1.0)
    assert _entities("ceiling", alone) == [0] * 12 + [1] * 3


def test_the_structures_are_a_checked_option() -> None:
    assert InstanceConfig().merge_structures == ("ceiling", "floor")
    assert InstanceConfig(merge_structures=[" Floor", "floor"]).merge_structures == ("floor",)
    for bad in ("floor", ("floor", ""), (3,)):
        with pytest.raises(InstanceConfigError, match="merge_structures"):
            InstanceConfig(merge_structures=bad)  # type: ignore[arg-type]
    config = BuildConfig.from_json({"instances": {"merge_structures": ["floor"]}})
    assert config.instances.merge_structures == ("floor",)
    assert config.result_json()["instances"]["merge_structures"] == ["floor"]
    with pytest.raises(BuildConfigError, match="merge_structures"):
        BuildConfig.from_json({"instances": {"merge_structures": "floor"}})
