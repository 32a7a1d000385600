"""KD-tree candidates give exactly the brute-force relations (same evidence, bit for bit)."""

from __future__ import annotations

import math

from hypothesis import given, settings
from hypothesis import strategies as st

from causalsplat.bench._edges_scenes import random_rooms
from causalsplat.graph import EdgeConfig, build_relations, build_relations_bruteforce
from causalsplat.graph._edge_candidates import all_pairs
from graph_store import Entity

# Grid values make exact ties (touching boxes, equal sizes, equal distances) common.
GRID = st.integers(-8, 8).map(lambda k: k / 4)
COORD = st.one_of(GRID, st.floats(-2, 2, allow_nan=False, allow_infinity=False))
SIZE = st.one_of(st.sampled_from([0.0, 0.25, 0.5, 1.0, 2.0]), st.floats(0, 2))
CATEGORY = st.sampled_from(["object", "object", "object", "cup", "floor", "Wall", "ceiling"])


@st.composite
def entities(draw: st.DrawFn) -> list[Entity]:
    n = draw(st.integers(0, 24))
    out = []
    for k in range(n):
        lo = [draw(COORD) for _ in range(3)]
        hi = [a + draw(SIZE) for a in lo]
        t = draw(st.sampled_from([0.0, 0.5, 1.0, 0.3]))
        centroid = [a + t * (b - a) for a, b in zip(lo, hi, strict=True)]
        out.append(Entity(k * 3 + 1, draw(CATEGORY), tuple(centroid), tuple(lo), tuple(hi)))
    return out


configs = st.builds(
    EdgeConfig,
    tau_v=st.floats(0, 0.95),
    horizontal_size_factor=st.floats(0, 2),
    horizontal_min_fraction=st.floats(0, 0.2),
    horizontal_max_fraction=st.floats(0.2, 1),
    touch_fraction=st.floats(0, 0.5),
    touch_height_factor=st.sampled_from([math.inf, 0.0, 0.5, 2.0]),
    support_overlap=st.floats(0.01, 1),
    contain_overlap=st.floats(0.01, 1),
    near_factor=st.floats(0, 3),
    relate_structural=st.booleans(),
)


@settings(max_examples=300, deadline=None)
@given(entities(), configs, st.sampled_from(["x", "y", "z"]))
def test_kdtree_matches_bruteforce_on_random_scenes(
    scene: list[Entity], config: EdgeConfig, up: str
) -> None:
    fast = build_relations(scene, config, up_axis=up)
    assert fast == build_relations_bruteforce(scene, config, up_axis=up)
    assert fast == build_relations(scene, config, up_axis=up, candidates="all")


@settings(max_examples=100, deadline=None)
@given(entities())
def test_kdtree_matches_bruteforce_with_default_config(scene: list[Entity]) -> None:
    assert build_relations(scene) == build_relations_bruteforce(scene)


def test_kdtree_matches_bruteforce_on_a_2000_entity_scene() -> None:
    scene = random_rooms(2000, seed=1)
    fast = build_relations(scene)
    assert fast == build_relations_bruteforce(scene)
    kinds = {r.type.value for r in fast}
    assert kinds == {"above", "below", "supported_by", "supports", "inside", "contains",
                     "near", "next_to"}  # fmt: skip
    assert len(fast) > 50_000


def test_all_pairs_enumerates_each_pair_once() -> None:
    for n in (0, 1, 2, 7, 1100):
        pairs = [(a, b) for i, j in all_pairs(n, block=64) for a, b in zip(i, j, strict=True)]
        assert len(pairs) == n * (n - 1) // 2 and len(set(pairs)) == len(pairs)
        assert all(0 <= a < b < n for a, b in pairs)
