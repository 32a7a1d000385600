"""Entities from an instance assignment: geometry, category vote, colour, provenance."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import scipy.sparse as sp

from causalsplat.colors import BASIC as PALETTE
from causalsplat.colors import hex_to_rgb
from causalsplat.field import MaskEvidence
from causalsplat.graph.nodes import NodeConfig, build_entities, build_provenance, mask_agreement
from causalsplat.instances import InstanceAssignment
from causalsplat.io.types import Camera, GaussianScene
from causalsplat.masks import MaskSet
from graph_store import AttributeSource


def _fixture() -> tuple[GaussianScene, InstanceAssignment, MaskEvidence, list[MaskSet]]:
    means = np.array([[0, 0, 0], [1, 0, 0], [0, 2, 0], [5, 5, 5], [6, 5, 5], [9, 9, 9]], float)
    rgb = np.array([PALETTE["red"]] * 3 + [PALETTE["blue"]] * 2 + [PALETTE["white"]])
    scene = GaussianScene.from_points(means, rgb, np.full(6, 0.05), opacity=0.9)
    labels = np.array([0, 0, 0, 1, 1, -1])
    assignment = InstanceAssignment(
        labels=labels,
        mask_entity=np.array([0, 1, 0, -1]),
        centers=np.eye(2, dtype=np.float32),
        score=np.ones(6, dtype=np.float32),
        n_clusters=3,
        n_noise_masks=1,
    )
    evidence = MaskEvidence(
        view=np.array([0, 0, 1, 1]),
        index=np.array([0, 1, 0, 2]),
        pixel_weight=np.array([10.0, 4.0, 6.0, 1.0]),
        features=np.eye(4, 2, dtype=np.float32),
        gaussian_weight=sp.csr_matrix((4, 6)),
    )
    m = np.zeros((3, 4, 4), dtype=bool)
    masksets = [
        MaskSet("a", m[:2], labels=("cup", "chair"), scores=np.array([1.0, 0.5])),
        MaskSet("b", m, labels=("mug", "x", "object"), scores=np.array([0.5, 1.0, 1.0])),
    ]
    return scene, assignment, evidence, masksets


def test_entity_geometry_category_vote_and_colour() -> None:
    scene, assignment, evidence, masksets = _fixture()
    entities = build_entities(scene, assignment, evidence, masksets, NodeConfig(bbox_quantile=0))
    assert [e.id for e in entities] == [0, 1]
    cup, chair = entities
    # votes of entity 0: cup 10 * 1.0, mug 6 * 0.5 -> cup with 10/13
    assert cup.category == "cup" and cup.confidence == pytest.approx(10 / 13)
    assert cup.centroid == pytest.approx((1 / 3, 2 / 3, 0.0), abs=1e-6)
    assert cup.bbox_min == pytest.approx((0, 0, 0)) and cup.bbox_max == pytest.approx((1, 2, 0))
    assert cup.point_count == 3
    attrs = {(a.key, a.value, a.source) for a in cup.attributes}
    assert ("color", "red", AttributeSource.GEOMETRY) in attrs
    assert ("label_vote", "cup:0.769", AttributeSource.MASK_VOTE) in attrs
    assert chair.category == "chair" and chair.confidence == pytest.approx(1.0)
    assert ("color", "blue", AttributeSource.GEOMETRY) in {
        (a.key, a.value, a.source) for a in chair.attributes
    }


def test_a_mask_votes_for_the_category_by_its_share_on_the_entity() -> None:
    # entity 1 holds a large "door" mask whose Gaussians all went to entity 0 (a fragment
    # clustered with a piece of wall), and a small "wall" mask drawing entity 1's own
    scene, assignment, evidence, masksets = _fixture()
    weight = np.zeros((4, 6))
    weight[0, :3] = 1.0  # mask 0 (cup, entity 0) on entity 0
    weight[1, :3] = 1.0  # mask 1 (entity 1) on entity 0's Gaussians only
    weight[2, 3:5] = 1.0  # mask 2 (entity 0) on entity 1's Gaussians only
    weight[3, 3:5] = 1.0
    evidence = replace(evidence, gaussian_weight=sp.csr_matrix(weight),
                       pixel_weight=np.array([1.0, 100.0, 100.0, 1.0]))  # fmt: skip
    assignment = replace(assignment, mask_entity=np.array([0, 1, 0, 1]))
    masksets = [
        MaskSet("a", masksets[0].masks, labels=("cup", "door")),
        MaskSet("b", masksets[1].masks, labels=("mug", "x", "wall")),
    ]
    np.testing.assert_allclose(mask_agreement(assignment, evidence), [1.0, 0.0, 0.0, 1.0])
    cup, wall = build_entities(scene, assignment, evidence, masksets)
    assert (cup.category, cup.confidence) == ("cup", 1.0)
    assert (wall.category, wall.confidence) == ("wall", 1.0)
    # no mask agrees with its entity: the votes by pixel weight alone
    evidence = replace(evidence, gaussian_weight=sp.csr_matrix((4, 6)))
    cup, door = build_entities(scene, assignment, evidence, masksets)
    assert door.category == "door" and door.confidence == pytest.approx(100 / 101)
    assert cup.category == "mug"


def test_unlabelled_masks_give_the_generic_category() -> None:
    scene, assignment, evidence, masksets = _fixture()
    bare = [MaskSet(ms.view, ms.masks) for ms in masksets]
    entities = build_entities(scene, assignment, evidence, bare)
    assert {e.category for e in entities} == {"object"}
    assert all(e.confidence is None for e in entities)


def test_provenance_records_every_mask_read() -> None:
    _, assignment, evidence, masksets = _fixture()
    cams = [Camera.look_at(n, [0.0, -3, 1], [0, 0, 0], [0, 0, 1], width=4, height=4,
                           fov_y_deg=60) for n in ("a.png", "b.png")]  # fmt: skip
    views, records = build_provenance(cams, masksets, evidence, assignment, {0, 1})
    assert [(v.id, v.name, v.width) for v in views] == [(0, "a", 4), (1, "b", 4)]
    assert [(r.view, r.index, r.entity, r.label) for r in records] == [
        (0, 0, 0, "cup"), (0, 1, 1, "chair"), (1, 0, 0, "mug"), (1, 1, None, "x"),
        (1, 2, None, "object"),
    ]  # fmt: skip


def _one_entity(n: int) -> tuple[InstanceAssignment, MaskEvidence]:
    """Every one of ``n`` Gaussians in entity 0, with no mask evidence."""
    assignment = InstanceAssignment(
        labels=np.zeros(n, dtype=np.int64), mask_entity=np.zeros(0, dtype=np.int64),
        centers=np.eye(1, 2, dtype=np.float32), score=np.ones(n, dtype=np.float32),
        n_clusters=1, n_noise_masks=0,
    )  # fmt: skip
    evidence = MaskEvidence(np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0),
                            np.zeros((0, 2), np.float32), sp.csr_matrix((0, n)))  # fmt: skip
    return assignment, evidence


def test_centroid_is_the_trimmed_mean_and_lies_in_the_box() -> None:
    # 95 Gaussians at x = 0 and 5 leaked ones at x = 100: the 10 %-trimmed box is x in
    # [0, 0]; the plain mean (5) would lie outside it, the trimmed mean is 0. Along y and
    # z every centre is 0.1 (float32): the mean of equal values must not round out of it.
    means = np.full((100, 3), 0.1, dtype=np.float32)
    means[:, 0] = 0.0
    means[95:, 0] = 100.0
    scene = GaussianScene.from_points(means, np.full((100, 3), 0.5), np.full(100, 0.05))
    assignment, evidence = _one_entity(100)
    (entity,) = build_entities(scene, assignment, evidence, [], NodeConfig(bbox_quantile=0.1))
    assert entity.bbox_min[0] == entity.bbox_max[0] == entity.centroid[0] == 0.0
    for axis in (1, 2):
        assert entity.bbox_min[axis] <= entity.centroid[axis] <= entity.bbox_max[axis]
        assert entity.centroid[axis] == pytest.approx(0.1, rel=1e-6)
    (plain,) = build_entities(scene, assignment, evidence, [], NodeConfig(bbox_quantile=0))
    assert plain.centroid[0] == pytest.approx(5.0) and plain.bbox_max[0] == 100.0


def test_colour_is_the_opacity_weighted_mean_of_the_base_colours() -> None:
    # two opaque red Gaussians and one nearly transparent blue one: the mean is red,
    # weighted by opacity (0.9, 0.9, 0.01), never the plain mean
    means = np.zeros((3, 3))
    rgb = np.array([PALETTE["red"], PALETTE["red"], PALETTE["blue"]])
    scene = GaussianScene.from_points(
        means, rgb, np.full(3, 0.05), opacity=np.array([0.9, 0.9, 0.01])
    )
    assignment, evidence = _one_entity(3)
    (entity,) = build_entities(scene, assignment, evidence, [])
    values = {a.key: a.value for a in entity.attributes}
    w = np.array([0.9, 0.9, 0.01])
    expected = (scene.colors.astype(np.float64) * w[:, None]).sum(0) / w.sum()
    got = hex_to_rgb(values["rgb"])
    assert got is not None and np.allclose(got, expected, atol=0.5 / 255 + 1e-9)
    assert values["color"] == "red"
