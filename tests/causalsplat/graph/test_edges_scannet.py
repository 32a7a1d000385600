"""Edges on the real ScanNet scene0000_00 object table, checked against its Sr3D labels."""

from __future__ import annotations

import csv
import json

import pytest

from causalsplat.graph import EdgeConfig, build_relations, build_relations_bruteforce
from graph_store import Entity
from tests.causalsplat.graph._boxes import find, triples
from tests.conftest import shared_data_path

pytestmark = pytest.mark.shared_data

EDGE_OF = {"supported-by": "supported_by", "supporting": "supports", "above": "above",
           "below": "below"}  # fmt: skip


def scene0000_entities() -> tuple[Entity, ...]:
    path = shared_data_path("scannet_scene0000_00", "language_gt", "objects_info_scene0000_00.json")
    table = json.loads(path.read_text())["objects"]
    return tuple(
        Entity(o["id"], o["label"], tuple(o["centroid"]), tuple(o["extension"][:3]),
               tuple(o["extension"][3:]), external_id=str(o["id"]))
        for o in table
    )  # fmt: skip


def sr3d_rows() -> list[tuple[int, str, int]]:
    path = shared_data_path("scannet_scene0000_00", "language_gt", "sr3d_scene0000_00.csv")
    with path.open(newline="") as handle:
        rows = list(csv.DictReader(handle))
    return sorted(
        {
            (int(r["target_id"]), EDGE_OF[r["reference_type"]], int(r["anchor_ids"][1:-1]))
            for r in rows
            if r["reference_type"] in EDGE_OF
        }
    )


@pytest.mark.parametrize("config", [EdgeConfig(), EdgeConfig.tuned_for_scannet()])
def test_sr3d_support_and_vertical_rows_hold(config: EdgeConfig) -> None:
    relations = build_relations(scene0000_entities(), config)
    expected = sr3d_rows()
    # curtain 6 on desk 7; nightstands 49/50 below curtain 6 / cabinet 41, and back.
    assert expected == [
        (6, "above", 49), (6, "supported_by", 7), (41, "above", 50),
        (49, "below", 6), (50, "below", 41),
    ]  # fmt: skip
    assert set(expected) <= triples(relations)
    curtain = find(relations, 6, "supported_by", 7)
    assert curtain["gap"] == pytest.approx(-0.0819, abs=1e-4)  # interpenetrating boxes
    assert curtain["overlap"] == pytest.approx(0.364, abs=1e-3)
    assert find(relations, 7, "supports", 6) == curtain
    cabinet = find(relations, 41, "above", 50)
    assert cabinet["vertical_ratio"] == pytest.approx(0.9918, abs=1e-4)
    assert cabinet["horizontal_distance"] < cabinet["horizontal_tolerance"]


def test_what_stands_on_the_floor_and_what_rests_on_furniture() -> None:
    entities = scene0000_entities()
    label = {e.id: e.category for e in entities}
    relations = build_relations(entities)
    assert relations == build_relations_bruteforce(entities)
    on_floor = {s for s, kind, d in triples(relations) if kind == "supported_by" and d == 9}
    assert label[9] == "floor"
    # The floor box spans z = -0.06..0.29 m; furniture stands at z ≈ 0.
    for furniture in (2, 7, 32, 33, 34, 37):  # table, desk, couch, fridge, coffee table, bed
        assert furniture in on_floor, label[furniture]
    assert not {s for s in on_floor if label[s] in ("wall", "ceiling", "floor")}
    assert (53, "supported_by", 3) in triples(relations)  # the toaster on the kitchen counter
    assert label[53] == "toaster" and label[3] == "kitchen counter"
    # Walls take part in nothing but are still entities of the graph.
    walls = {e.id for e in entities if e.category == "wall"}
    assert walls and not {t for t in triples(relations) if t[0] in walls or t[2] in walls}
