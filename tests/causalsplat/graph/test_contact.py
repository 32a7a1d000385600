"""Support from surfaces that touch (``graph/contact.py``): in a scene built from Gaussians,
a support pair whose boxes pass the touch rule but whose points stay apart is dropped,
before the supporters are reduced, so the object falls back to what it does touch."""

from __future__ import annotations

import numpy as np
import pytest

from causalsplat.graph.config import EdgeConfig, EdgeConfigError
from causalsplat.graph.contact import Surfaces
from causalsplat.graph.edges import build_relations, build_relations_bruteforce
from graph_store import Entity, RelationType


def box(i: int, category: str, lo: tuple[float, ...], hi: tuple[float, ...]) -> Entity:
    centre = tuple((a + b) / 2 for a, b in zip(lo, hi, strict=True))
    return Entity(i, category, centre, lo, hi)  # type: ignore[arg-type]


def cloud(lo: tuple[float, ...], hi: tuple[float, ...], step: float = 0.02) -> np.ndarray:
    """Points on the surface of a box (its six faces), ``step`` apart."""
    axes = [np.arange(a, b + step / 2, step) for a, b in zip(lo, hi, strict=True)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    on_face = np.zeros(len(grid), dtype=bool)
    for k in range(3):
        on_face |= np.isclose(grid[:, k], lo[k]) | np.isclose(grid[:, k], hi[k])
    return grid[on_face]


FLOOR = ((-2.0, -2.0, -0.02), (4.0, 4.0, 0.0))
COUNTER = ((0.0, 0.0, 0.0), (2.0, 0.6, 0.9))
RACK = ((0.2, 0.1, 0.9), (0.6, 0.5, 1.1))
# wall cabinets 12 cm above the rack: within the boxes' touch tolerance, touching nothing
CABINETS = ((0.1, 0.05, 1.22), (0.8, 0.45, 1.9))
PARTS = {0: ("floor", FLOOR), 1: ("kitchen counter", COUNTER), 2: ("dish rack", RACK),
         3: ("kitchen cabinets", CABINETS)}  # fmt: skip
SCENE = tuple(box(i, c, lo, hi) for i, (c, (lo, hi)) in PARTS.items())
SURFACES = Surfaces({i: cloud(lo, hi) for i, (_, (lo, hi)) in PARTS.items()}, radius=0.05)


def supporters(relations: tuple, entity: int) -> set[int]:  # type: ignore[type-arg]
    return {r.dst for r in relations if r.type is RelationType.SUPPORTED_BY and r.src == entity}


def test_boxes_alone_put_the_wall_cabinets_on_the_dish_rack() -> None:
    config = EdgeConfig(touch_fraction=0.1)
    assert supporters(build_relations(SCENE, config), 3) == {2}


def test_touching_surfaces_keep_what_rests_and_drop_what_hovers() -> None:
    config = EdgeConfig(touch_fraction=0.1)
    relations = build_relations(SCENE, config, surfaces=SURFACES)
    assert supporters(relations, 3) == set()  # the cabinets hang on the wall
    assert supporters(relations, 2) == {1}  # the rack stands on the counter
    assert supporters(relations, 1) == {0}  # the floor is never checked
    assert not any(r.type is RelationType.SUPPORTS and r.src == 2 for r in relations)
    # the reference path applies the same rule
    assert build_relations_bruteforce(SCENE, config, surfaces=SURFACES) == relations


def test_an_entity_without_points_keeps_the_box_rule() -> None:
    partial = Surfaces({i: p for i, p in SURFACES.points.items() if i != 3}, radius=0.05)
    config = EdgeConfig(touch_fraction=0.1)
    assert supporters(build_relations(SCENE, config, surfaces=partial), 3) == {2}


def test_a_few_stray_points_are_no_contact() -> None:
    cabinets = SURFACES.points[3]
    stray = np.vstack([cabinets, [[0.4, 0.3, 1.12]]])  # one Gaussian dropped onto the rack
    surfaces = Surfaces({**SURFACES.points, 3: stray}, radius=0.05)
    assert not surfaces.touching(3, 2)
    assert Surfaces({**SURFACES.points, 3: stray[-1:]}, radius=0.05).touching(3, 2)


def test_contact_options_are_checked() -> None:
    with pytest.raises(ValueError, match="radius must be a positive finite number"):
        Surfaces({}, radius=0.0)
    with pytest.raises(EdgeConfigError, match="contact_scales"):
        EdgeConfig(contact_scales=-1.0)
    assert EdgeConfig().contact_scales == 3.0
