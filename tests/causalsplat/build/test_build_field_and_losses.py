"""The stages before the instances on their own (``build_field``), masks clustered
elsewhere (``assign_instances(mask_clusters=...)``) and the exact-mask loss table."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from causalsplat.bench._build_losses import mask_objects, stage_losses
from causalsplat.build import SceneFolder, build_scene
from causalsplat.build.pipeline import build_field, mask_labels
from causalsplat.field.types import MaskEvidence
from causalsplat.instances import assign_instances, cluster_masks


def _kwargs(folder: SceneFolder, evidence: MaskEvidence) -> dict[str, Any]:
    g = folder.gaussians
    return dict(means=g.means, scales=g.scales, quats=g.quats,
                mask_labels=mask_labels(folder, evidence), colors=g.colors)  # fmt: skip


def test_the_field_and_its_evidence_give_the_build_s_entities(tiny_folder: Path) -> None:
    scene, config, field, evidence = build_field(tiny_folder)
    labels = assign_instances(field, evidence, config.instances, **_kwargs(scene, evidence))
    built = build_scene(tiny_folder, cache_dir=False)
    assert np.array_equal(labels.labels, built.gaussian_labels)


def test_masks_clustered_elsewhere_replace_hdbscan(tiny_folder: Path) -> None:
    scene, config, field, evidence = build_field(tiny_folder)
    kwargs = _kwargs(scene, evidence)
    own = assign_instances(field, evidence, config.instances, **kwargs)
    given = assign_instances(field, evidence, config.instances,
                             mask_clusters=cluster_masks(evidence.features, config.instances),
                             **kwargs)  # fmt: skip
    assert np.array_equal(own.labels, given.labels)
    # every mask in one cluster: one entity, whatever the features say
    together = np.zeros(evidence.n, dtype=np.int64)
    one = assign_instances(field, evidence, config.instances, mask_clusters=together, **kwargs)
    assert set(np.unique(one.labels)) <= {-1, 0}
    with pytest.raises(ValueError, match=r"mask_clusters must be \(\d+,\) integers"):
        wrong = np.zeros(evidence.n + 1, dtype=np.int64)
        assign_instances(field, evidence, config.instances, mask_clusters=wrong, **kwargs)


def test_the_loss_table_bounds_the_build(tiny_folder: Path) -> None:
    scene, _, _, evidence = build_field(tiny_folder)
    assert scene.gt_labels is not None
    objects = mask_objects(evidence, scene.gt_labels)
    assert objects.shape == (evidence.n,) and (objects >= 0).mean() > 0.9
    lines, data = stage_losses(tiny_folder, "the build (tiny room)")
    built = build_scene(tiny_folder, cache_dir=False)
    assert built.quality is not None
    assert lines[2].startswith("| the build (tiny room) | ")
    assert data["the build (tiny room)"]["pq"] == pytest.approx(built.quality.pq)
    visible = data["visibility: GT object of each Gaussian some mask draws"]["pq"]
    # what the views tell bounds every row but the one given the truth of the weakly seen
    # Gaussians, which include those no mask draws
    oracle = "the build, weakly seen Gaussians given their GT objects"
    assert visible >= max(v["pq"] for k, v in data.items() if isinstance(v, dict) and k != oracle)
    assert data[oracle]["pq"] >= data["the build (tiny room)"]["pq"]
    assert 0 <= data["weak_share"] <= 1 and len([ln for ln in lines if ln.startswith("| ")]) == 6
