"""Surface graph weights and harmonic labels, by hand; the occluded-floor case end to end."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
import scipy.sparse as sp

from causalsplat.field import FeatureField, FieldConfig, MaskEvidence
from causalsplat.instances import InstanceConfig, assign_instances, propagate
from causalsplat.instances.propagate import harmonic_labels, local_planes, surface_graph
from causalsplat.io._geometry import quat_to_rotmat

IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])  # wxyz: local axes = world axes
DISC = np.array([0.1, 0.1, 0.01])  # a disc in the x-y plane, normal z, thickness 0.01


def _three_discs() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    # A and B in one plane 0.1 apart; C 0.02 above A, parallel to it.
    means = np.array([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.0, 0.0, 0.02]])
    return means, np.tile(DISC, (3, 1)), np.tile(IDENTITY, (3, 1))


def test_surface_graph_weights_by_hand() -> None:
    means, scales, quats = _three_discs()
    w = surface_graph(means, scales, quats, k=2, radius=1.0).toarray()
    # edge lengths 0.1 (A-B), 0.02 (A-C), sqrt(0.0104) (B-C), each seen from both ends:
    # median s = 0.1. Offsets from the tangent planes: A-B 0, A-C and B-C 0.02 on both
    # sides, e = 2 * 0.02**2 / (2 * 0.01**2) = 4.
    bc = math.sqrt(0.1**2 + 0.02**2)
    expected = {
        (0, 1): math.exp(-1.0),
        (0, 2): math.exp(-(0.2**2)) * math.exp(-2.0),
        (1, 2): math.exp(-((bc / 0.1) ** 2)) * math.exp(-2.0),
    }
    for (i, j), value in expected.items():
        assert w[i, j] == pytest.approx(value, rel=1e-9) and w[j, i] == w[i, j]
    assert np.all(np.diag(w) == 0)
    # distance alone, and spheres (no normal) weigh the same way
    plain = surface_graph(means, scales, quats, k=2, radius=1.0, coplanar=False).toarray()
    assert plain[0, 2] == pytest.approx(math.exp(-(0.2**2)), rel=1e-9)
    spheres = surface_graph(means, np.full((3, 3), 0.1), quats, k=2, radius=1.0).toarray()
    np.testing.assert_allclose(spheres, plain, rtol=1e-12)
    assert surface_graph(means, scales, None, k=2, radius=1.0).toarray() == pytest.approx(plain)


def test_a_rotated_scene_gives_the_same_weights() -> None:
    means, scales, quats = _three_discs()
    half = math.pi / 5  # rotate everything by 2*pi/5 about the axis (1, 2, 3)
    axis = np.array([1.0, 2.0, 3.0]) / math.sqrt(14.0)
    q = np.array([math.cos(half), *(math.sin(half) * axis)])
    rot = quat_to_rotmat(q[None])[0]
    # the rotated discs' orientation is q * identity = q
    turned = surface_graph(means @ rot.T, scales, np.tile(q, (3, 1)), k=2, radius=1.0)
    np.testing.assert_allclose(
        turned.toarray(), surface_graph(means, scales, quats, k=2, radius=1.0).toarray(),
        rtol=1e-9, atol=1e-15,
    )  # fmt: skip


@pytest.mark.parametrize("unit", [1e-3, 1e4])
def test_millimetres_and_kilometres_give_the_same_graph(unit: float) -> None:
    rng = np.random.default_rng(0)
    means = rng.uniform(0, 1, (200, 3))
    scales = rng.uniform(0.01, 0.05, (200, 3))
    quats = rng.standard_normal((200, 4))
    ref = surface_graph(means, scales, quats, k=8, radius=0.15)
    scaled = surface_graph(means * unit, scales * unit, quats, k=8, radius=0.15 * unit)
    assert ref.nnz > 0 and np.all(np.isfinite(ref.data))
    np.testing.assert_allclose(scaled.toarray(), ref.toarray(), rtol=1e-9, atol=1e-300)


def test_degenerate_inputs_give_finite_graphs() -> None:
    means, _, quats = _three_discs()
    # zero-thickness discs: in-plane neighbours joined, the offset one cut off
    flat = surface_graph(means, np.tile([0.1, 0.1, 0.0], (3, 1)), quats, k=2, radius=1.0)
    assert flat[0, 1] == pytest.approx(math.exp(-1.0)) and flat[0, 2] == 0 and flat[1, 2] == 0
    # coincident centres, one point, a radius of 0: finite, nothing stored as zero
    same = surface_graph(np.zeros((4, 3)), np.full((4, 3), 0.1), None, k=3, radius=1.0)
    assert same.nnz == 12 and np.allclose(same.data, 1.0)
    assert surface_graph(np.zeros((1, 3)), np.ones((1, 3)), None, k=3, radius=1.0).nnz == 0
    assert surface_graph(means, np.ones((3, 3)), None, k=2, radius=0.0).nnz == 0
    far = surface_graph(means, np.ones((3, 3)), None, k=2, radius=1e-3)
    assert far.nnz == 0


def test_harmonic_labels_follow_the_random_walk() -> None:
    # path 0-1-2-3-4, conductances 1, 1, 3, 3; node 0 fixed to label 0, node 4 to label 1.
    # The walk from node i reaches 0 first with probability R(i, 4) / R(0, 4), R the
    # resistance along the path (1 + 1 + 1/3 + 1/3 = 8/3): 0.625, 0.25, 0.125 for 1, 2, 3.
    w = sp.lil_matrix((7, 7))
    for i, j, c in [(0, 1, 1.0), (1, 2, 1.0), (2, 3, 3.0), (3, 4, 3.0), (5, 6, 1.0)]:
        w[i, j] = w[j, i] = c
    labels = np.array([0, 1, 0, 0, 1, -1, 2])
    fixed = np.array([True, False, False, False, True, False, False])
    out = harmonic_labels(w.tocsr(), labels, fixed)
    # nodes 5 and 6 reach no fixed node: they keep their labels
    assert out.tolist() == [0, 0, 1, 1, 1, -1, 2]
    assert labels.tolist() == [0, 1, 0, 0, 1, -1, 2]  # the input is not changed
    # a fixed node with no label (-1) is not fixed
    out = harmonic_labels(w.tocsr(), np.array([0, 1, 0, 0, -1, -1, 2]), fixed)
    assert out[:5].tolist() == [0, 0, 0, 0, 0]
    # nothing fixed: unchanged; everything fixed: only the unlabelled node 5 is free
    assert harmonic_labels(w.tocsr(), labels, np.zeros(7, bool)).tolist() == labels.tolist()
    assert harmonic_labels(w.tocsr(), labels, np.ones(7, bool)).tolist() == [0, 1, 0, 0, 1, 2, 2]


def _floor_under_table() -> tuple[FeatureField, MaskEvidence, np.ndarray, np.ndarray, np.ndarray]:
    """An 8x8 floor of discs (spacing 0.1, z = 0) and a 4x4 low table top 0.05 above its middle.

    Three views see the open floor in a floor mask and the table top in a table mask. The
    16 floor discs under the top are seen only through it: they carry 2 % weight inside
    the table masks and none inside the floor masks, and their features lean to the table.
    """
    g = np.arange(8) * 0.1
    floor = np.array([[x, y, 0.0] for x in g for y in g])
    top = np.array([[x, y, 0.05] for x in g[2:6] for y in g[2:6]])
    means = np.vstack([floor, top])
    n = means.shape[0]
    under = np.zeros(n, dtype=bool)
    under[:64] = np.all((floor[:, :2] > 0.15) & (floor[:, :2] < 0.55), axis=1)
    is_top = np.arange(n) >= 64
    e1, e2 = np.eye(3)[0], np.eye(3)[1]
    feats = np.where((is_top | under)[:, None], e2, e1).astype(np.float32)
    w = np.zeros((6, n))
    for v in range(3):
        w[2 * v, ~is_top & ~under] = 1.0  # floor mask
        w[2 * v + 1, is_top] = 1.0  # table mask
        w[2 * v + 1, under] = 0.02
    field = FeatureField(feats, np.ones(n, bool), np.ones(n, bool), (), FieldConfig(feature_dim=3))
    evidence = MaskEvidence(
        view=np.repeat(np.arange(3), 2), index=np.tile([0, 1], 3), pixel_weight=np.ones(6),
        features=np.array([e1, e2] * 3, dtype=np.float32), gaussian_weight=sp.csr_matrix(w),
    )  # fmt: skip
    scales = np.tile([0.05, 0.05, 0.005], (n, 1))
    return field, evidence, means, scales, under


def test_floor_seen_through_a_table_goes_to_the_floor() -> None:
    field, evidence, means, scales, under = _floor_under_table()
    quats = np.tile(IDENTITY, (means.shape[0], 1))
    config = InstanceConfig(min_gaussians=1)
    out = assign_instances(field, evidence, config, means=means, scales=scales, quats=quats)
    floor, table = out.labels[0], out.labels[-1]
    assert floor != table and floor >= 0 and table >= 0
    assert np.all(out.labels[:64] == floor) and np.all(out.labels[64:] == table)
    assert np.all(out.score[under] == 0) and np.all(out.score[~under] > 0)
    # without the propagation the votes, all cast through the table top, win
    off = InstanceConfig(min_gaussians=1, propagate_sigmas=0.0)
    voted = assign_instances(field, evidence, off, means=means, scales=scales, quats=quats)
    assert np.all(voted.labels[under] == voted.labels[-1])
    # with distance alone, the table top 0.05 above (nearer than the next floor disc) wins
    dist = InstanceConfig(min_gaussians=1, propagate_coplanar=False)
    plain = assign_instances(field, evidence, dist, means=means, scales=scales, quats=quats)
    assert np.all(plain.labels[under] == plain.labels[-1])
    # evidence above the floor fraction keeps the vote, without smoothing; smoothed, the
    # floor all around outvotes them (seen 0.02 times the median, they barely count)
    keep = InstanceConfig(min_gaussians=1, min_evidence=0.01, vote_smoothing=0.0)
    kept = assign_instances(field, evidence, keep, means=means, scales=scales, quats=quats)
    assert np.all(kept.labels[under] == kept.labels[-1])
    smoothed = assign_instances(field, evidence, replace(keep, vote_smoothing=10.0),
                                means=means, scales=scales, quats=quats)  # fmt: skip
    assert np.all(smoothed.labels[:64] == smoothed.labels[0])
    assert np.all(smoothed.labels[64:] == smoothed.labels[-1])
    assert smoothed.labels[-1] != smoothed.labels[0]


def _hidden_side() -> tuple[FeatureField, MaskEvidence, np.ndarray, np.ndarray]:
    """A row of round Gaussians: 0-7 a cabinet panel (cabinet masks), 8-11 the barely seen
    side of a microwave beside it (2 % weight in the microwave masks, features of the
    microwave), 12-15 the microwave's front (microwave masks), 0.15 further on. By
    distance alone the side continues the panel (0.1 away) more than the front."""
    x = np.concatenate([np.arange(12) * 0.1, 1.25 + np.arange(4) * 0.1])
    means = np.stack([x, np.zeros(16), np.zeros(16)], axis=1)
    e1, e2 = np.eye(3)[0], np.eye(3)[1]
    feats = np.array([e2] * 8 + [e1] * 8, dtype=np.float32)
    w = np.zeros((6, 16))
    for v in range(3):
        w[2 * v, :8] = 1.0
        w[2 * v + 1, 12:] = 1.0
        w[2 * v + 1, 8:12] = 0.02
    field = FeatureField(feats, np.ones(16, bool), np.ones(16, bool), (),
                         FieldConfig(feature_dim=3))  # fmt: skip
    evidence = MaskEvidence(
        view=np.repeat(np.arange(3), 2), index=np.tile([0, 1], 3), pixel_weight=np.ones(6),
        features=np.array([e2, e1] * 3, dtype=np.float32), gaussian_weight=sp.csr_matrix(w),
    )  # fmt: skip
    return field, evidence, means, np.full((16, 3), 0.07)


def test_a_barely_seen_side_follows_its_features_not_the_surface_it_touches() -> None:
    field, evidence, means, scales = _hidden_side()
    config = InstanceConfig(min_gaussians=1)
    out = assign_instances(field, evidence, config, means=means, scales=scales)
    cabinet, microwave = out.labels[0], out.labels[-1]
    assert out.labels.tolist() == [cabinet] * 8 + [microwave] * 8
    plain = InstanceConfig(min_gaussians=1, propagate_feature_power=0.0)
    out = assign_instances(field, evidence, plain, means=means, scales=scales)
    assert (out.labels[8:12] == cabinet).sum() >= 2


def _back_against_a_wall() -> tuple[FeatureField, MaskEvidence, np.ndarray, np.ndarray]:
    """A row of round Gaussians: 0-7 a white wall (wall masks), 8-11 the brown back of a
    cabinet standing flush against it, which no view sees and no mask supervised, 12-15
    the cabinet's brown front (cabinet masks), 0.15 further on. By distance alone the back
    continues the wall (0.1 away) more than the front."""
    field, evidence, means, scales = _hidden_side()
    w = evidence.gaussian_weight.toarray()
    w[:, 8:12] = 0.0
    supervised = np.ones(16, bool)
    supervised[8:12] = False
    feats = field.features.copy()
    feats[8:12] = 0.0
    field = FeatureField(feats, field.active, supervised, (), field.config)
    evidence = replace(evidence, gaussian_weight=sp.csr_matrix(w))
    return field, evidence, means, scales


def test_an_unseen_back_takes_the_object_its_colour_continues() -> None:
    field, evidence, means, scales = _back_against_a_wall()
    white, brown = [0.9, 0.9, 0.88], [0.4, 0.25, 0.12]  # 60 apart in CIELAB
    colors = np.array([white] * 8 + [brown] * 8)
    config = InstanceConfig(min_gaussians=1)
    out = assign_instances(field, evidence, config, means=means, scales=scales, colors=colors)
    wall, cabinet = out.labels[0], out.labels[-1]
    assert wall != cabinet and out.labels.tolist() == [wall] * 8 + [cabinet] * 8
    # without the colours (or with the weighting off) the nearer wall takes the back
    off = replace(config, propagate_colour_sigma=0.0)
    for plain in (
        assign_instances(field, evidence, config, means=means, scales=scales),
        assign_instances(field, evidence, off, means=means, scales=scales, colors=colors),
    ):
        assert (plain.labels[8:12] == plain.labels[0]).sum() >= 2
    # one colour everywhere changes nothing
    same = assign_instances(field, evidence, config, means=means, scales=scales,
                            colors=np.full((16, 3), 0.5))  # fmt: skip
    assert np.array_equal(
        same.labels, assign_instances(field, evidence, config, means=means, scales=scales).labels
    )


@pytest.mark.parametrize("bad", [np.full((15, 3), 0.5), np.full((16, 4), 0.5),
                                 np.full((16, 3), np.nan)])  # fmt: skip
def test_colours_of_the_wrong_shape_or_not_finite_are_refused(bad: np.ndarray) -> None:
    field, evidence, means, scales = _back_against_a_wall()
    with pytest.raises(ValueError, match=r"colors must be \(16, 3\) finite"):
        assign_instances(field, evidence, InstanceConfig(min_gaussians=1), means=means,
                         scales=scales, colors=bad)  # fmt: skip


def test_colour_weights_are_the_cielab_distance_block_by_block(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Each edge times exp(-(dE / sigma)^2 / 2), dE computed in float64 from the CIELAB of
    both ends (checked against colour-science formulas written out here), a block of edges
    at a time: the same graph whatever the block."""
    rng = np.random.default_rng(5)
    n = 300
    src, dst = np.repeat(np.arange(n), 5), rng.integers(0, n, 5 * n)
    graph = sp.csr_matrix((rng.random(5 * n), (src, dst)), shape=(n, n))
    colors = rng.random((n, 3))
    whole = propagate.colour_weighted(graph, colors, 20.0)

    def lab(rgb: np.ndarray) -> np.ndarray:  # sRGB (IEC 61966-2-1) -> XYZ (D65) -> L*a*b*
        lin = np.where(rgb <= 0.04045, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)
        m = np.array([[0.4124564, 0.3575761, 0.1804375], [0.2126729, 0.7151522, 0.0721750],
                      [0.0193339, 0.1191920, 0.9503041]])  # fmt: skip
        xyz = lin @ m.T / np.array([0.95047, 1.0, 1.08883])
        f = np.where(xyz > (6 / 29) ** 3, np.cbrt(xyz), xyz / (3 * (6 / 29) ** 2) + 4 / 29)
        return np.stack([116 * f[:, 1] - 16, 500 * (f[:, 0] - f[:, 1]),
                         200 * (f[:, 1] - f[:, 2])], axis=1)  # fmt: skip

    coo = graph.tocoo()
    de = np.linalg.norm(lab(colors[coo.row]) - lab(colors[coo.col]), axis=1)
    expected = sp.csr_matrix((coo.data * np.exp(-0.5 * (de / 20.0) ** 2), (coo.row, coo.col)),
                             shape=graph.shape)  # fmt: skip
    assert abs(whole - expected).max() < 1e-6
    monkeypatch.setattr(propagate, "EDGE_BLOCK", 7)
    blocks = propagate.colour_weighted(graph, colors, 20.0)
    assert (whole != blocks).nnz == 0 and np.array_equal(whole.data, blocks.data)


def test_feature_agreement_block_by_block_equals_all_at_once(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The agreement is computed a block of edges at a time (memory on dense captures):
    the weighted graph is the same, bit for bit, whatever the block."""
    from causalsplat.instances import propagate

    rng = np.random.default_rng(4)
    n = 500
    src, dst = np.repeat(np.arange(n), 6), rng.integers(0, n, 6 * n)
    graph = sp.csr_matrix((rng.random(6 * n), (src, dst)), shape=(n, n))
    graph = graph + graph.T
    features = rng.standard_normal((n, 8)).astype(np.float32)
    features /= np.linalg.norm(features, axis=1, keepdims=True)
    known = rng.random(n) > 0.3
    whole = propagate.feature_weighted(graph, features, 2.0, known)
    monkeypatch.setattr(propagate, "EDGE_BLOCK", 7)
    blocks = propagate.feature_weighted(graph, features, 2.0, known)
    assert (whole != blocks).nnz == 0 and np.array_equal(whole.data, blocks.data)


def _corner(spacing: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Spheres on a 7 x 7 floor (z = 0) and a 7 x 7 wall (x = 0, above the floor)."""
    ticks = np.arange(7) * spacing
    floor = np.array([[x, y, 0.0] for x in ticks[1:] for y in ticks])
    wall = np.array([[0.0, y, z] for y in ticks for z in ticks])
    return np.vstack([floor, wall]), np.full((len(floor) + len(wall), 3), 0.5 * spacing)


def test_spheres_take_their_plane_from_their_neighbours() -> None:
    means, scales = _corner()
    normal, thin, flat = local_planes(means, scales, None)
    mid_floor = int(np.flatnonzero((means == [3.0, 3.0, 0.0]).all(axis=1))[0])
    mid_wall = int(np.flatnonzero((means == [0.0, 3.0, 3.0]).all(axis=1))[0])
    np.testing.assert_allclose(np.abs(normal[mid_floor]), [0, 0, 1], atol=1e-12)
    np.testing.assert_allclose(np.abs(normal[mid_wall]), [1, 0, 0], atol=1e-12)
    # centres exactly in a plane: the thickness is the floor's, a quarter of the size
    assert thin[mid_floor] == pytest.approx(0.25 * 0.5) and flat[mid_floor] == 1.0
    # a floor sphere one step from the wall: its edge up the wall (sqrt 2 long) weighs
    # e**-1 of its edge along the floor (1 long) by distance alone; the planes cut it down
    graph = surface_graph(means, scales, None, k=8, radius=1.5).toarray()
    plain = surface_graph(means, scales, None, k=8, radius=1.5, coplanar=False).toarray()
    at = {tuple(p): i for i, p in enumerate(means.tolist())}
    a, along, up = at[(1.0, 3.0, 0.0)], at[(2.0, 3.0, 0.0)], at[(0.0, 3.0, 1.0)]
    assert plain[a, up] == pytest.approx(plain[a, along] * math.exp(-1.0), rel=1e-9)
    assert graph[a, along] > 0.5 * plain[a, along]  # the corner tilts the floor's plane
    assert 0 < graph[a, up] < 0.05 * plain[a, up]  # 0.82 and 0.03 of them


def test_a_gaussians_own_plane_wins_when_it_is_flatter() -> None:
    # discs lying in x-y planes stacked along z: their centres make a vertical line (no
    # plane), their shape says z
    means = np.array([[0.0, 0.0, 0.1 * i] for i in range(10)])
    quats = np.tile(IDENTITY, (10, 1))
    normal, thin, flat = local_planes(means, np.tile(DISC, (10, 1)), quats)
    np.testing.assert_allclose(np.abs(normal), np.tile([0, 0, 1.0], (10, 1)), atol=1e-12)
    assert thin.tolist() == [0.01] * 10 and flat.tolist() == [1.0] * 10


def test_local_planes_in_blocks_equal_one_block(monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(3)
    means = rng.uniform(0, 1, (500, 3)) * [1, 1, 0.05]
    scales = rng.uniform(0.01, 0.03, (500, 3))
    whole = local_planes(means, scales, None)
    monkeypatch.setattr(propagate, "PLANE_BLOCK", 37)
    for a, b in zip(whole, local_planes(means, scales, None), strict=True):
        np.testing.assert_array_equal(a, b)
