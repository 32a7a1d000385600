"""Validation and canonical ordering of the scene-graph types."""

from __future__ import annotations

import math

import numpy as np
import pytest

from graph_store import (
    Attribute,
    Entity,
    EntityNotFound,
    InvalidSceneError,
    MaskRecord,
    Relation,
    RelationType,
    SceneGraph,
    SceneMeta,
    View,
)


def box(i: int, category: str = "cup", **kw: object) -> Entity:
    return Entity(i, category, (i, 0, 0.5), (i - 0.5, -0.5, 0), (i + 0.5, 0.5, 1), **kw)  # type: ignore[arg-type]


def test_relation_vocabulary_inverses_and_view_dependence() -> None:
    assert {t.value for t in RelationType} == {
        "above", "below", "supported_by", "supports", "inside", "contains", "near", "next_to",
        "left_of", "right_of", "in_front_of", "behind",
    }  # fmt: skip
    for t in RelationType:
        assert t.inverse.inverse is t
    assert RelationType.NEAR.is_symmetric and not RelationType.ABOVE.is_symmetric
    assert RelationType.ABOVE.inverse is RelationType.BELOW
    assert {t for t in RelationType if t.is_view_dependent} == {
        RelationType.LEFT_OF, RelationType.RIGHT_OF, RelationType.IN_FRONT_OF, RelationType.BEHIND,
    }  # fmt: skip


def test_unknown_relation_name_is_a_typed_error_listing_the_vocabulary() -> None:
    with pytest.raises(InvalidSceneError, match=r"unknown relation 'on_top_of'.*supported_by"):
        Relation(0, 1, "on_top_of")  # type: ignore[arg-type]


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_coordinates_are_refused(bad: float) -> None:
    with pytest.raises(InvalidSceneError, match=r"centroid of entity 3\[1\] must be finite"):
        Entity(3, "cup", (0, bad, 0), (0, 0, 0), (1, 1, 1))
    with pytest.raises(InvalidSceneError, match="evidence 'distance'"):
        Relation(0, 1, RelationType.NEAR, {"distance": bad})


def test_entity_normalises_numpy_and_lists_to_float_tuples() -> None:
    centroid = np.array([1, 2, 3], dtype=np.float32)
    e = Entity(np.int64(2), "cup", centroid, [0, 0, 0], (4, 4, 4))  # type: ignore[arg-type]
    assert e.id == 2 and type(e.id) is int
    assert e.centroid == (1.0, 2.0, 3.0) and all(type(v) is float for v in e.centroid)
    assert e.size == (4.0, 4.0, 4.0) and e.volume == 64.0


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"category": ""}, "category of entity 0 must not be empty"),
        ({"category": "a\x00b"}, "NUL"),
        ({"category": "\udc80"}, "lone surrogate"),
        ({"bbox_min": (2, 0, 0)}, "min x=2.0 > max x=1.0"),
        ({"confidence": 1.5}, r"confidence of entity 0 must be in \[0, 1\]"),
        ({"point_count": -1}, "point_count of entity 0 must be >= 0"),
        ({"centroid": (1, 2)}, "must be three numbers, got 2"),
    ],
)
def test_entity_validation_messages(kwargs: dict[str, object], message: str) -> None:
    args: dict[str, object] = {
        "id": 0, "category": "cup", "centroid": (0, 0, 0),
        "bbox_min": (0, 0, 0), "bbox_max": (1, 1, 1),
    }  # fmt: skip
    args.update(kwargs)
    with pytest.raises(InvalidSceneError, match=message):
        Entity(**args)  # type: ignore[arg-type]


def test_duplicate_attribute_is_refused_and_attributes_are_sorted() -> None:
    e = box(0, attributes=(Attribute("material", "wood"), Attribute("color", "red")))
    assert [a.key for a in e.attributes] == ["color", "material"]
    assert e.attribute_values("color") == ("red",)
    with pytest.raises(InvalidSceneError, match="attribute color='red' twice"):
        box(0, attributes=(Attribute("color", "red"), Attribute("color", "red", "vlm")))  # type: ignore[arg-type]


def test_scene_graph_is_canonical_whatever_the_input_order() -> None:
    meta = SceneMeta("s")
    a = SceneGraph(meta, (box(2), box(0), box(1)), (Relation(2, 0, "near"), Relation(0, 2, "near")))
    b = SceneGraph(meta, (box(0), box(1), box(2)), (Relation(0, 2, "near"), Relation(2, 0, "near")))
    assert a == b
    assert [e.id for e in a.entities] == [0, 1, 2]
    assert a.get_entity(1) == box(1) and a.find_entity(9) is None and not a.has_entity(9)
    with pytest.raises(EntityNotFound, match="scene 's' has no entity 9"):
        a.get_entity(9)


@pytest.mark.parametrize(
    ("entities", "relations", "message"),
    [
        ((box(0), box(0)), (), "duplicate entity id 0"),
        ((box(0, external_id="x"), box(1, external_id="x")), (), "duplicate external id 'x'"),
        ((box(0),), (Relation(0, 5, "near"),), "refers to missing entity 5"),
        ((box(0), box(1)), (Relation(0, 1, "near"), Relation(0, 1, "near")), "duplicate relation"),
        ((box(0), box(1)), (Relation(0, 1, "left_of"),), "view-dependent"),
    ],
)
def test_scene_graph_validation(
    entities: tuple[Entity, ...], relations: tuple[Relation, ...], message: str
) -> None:
    with pytest.raises(InvalidSceneError, match=message):
        SceneGraph(SceneMeta("s"), entities, relations)


def test_self_relation_and_mask_references_are_checked() -> None:
    with pytest.raises(InvalidSceneError, match="relates an entity to itself"):
        Relation(1, 1, "near")
    with pytest.raises(InvalidSceneError, match="refers to missing view 3"):
        SceneGraph(SceneMeta("s"), (box(0),), masks=(MaskRecord(3, 0, 0),))
    with pytest.raises(InvalidSceneError, match="refers to missing entity 7"):
        SceneGraph(
            SceneMeta("s"), (box(0),), views=(View(0, "a", 4, 4),), masks=(MaskRecord(0, 0, 7),)
        )


def test_scene_meta_validation_and_created_at_is_not_compared() -> None:
    from datetime import UTC, datetime

    assert SceneMeta("s", created_at=datetime.now(UTC)) == SceneMeta("s")
    with pytest.raises(InvalidSceneError, match="up axis"):
        SceneMeta("s", up_axis="w")
    with pytest.raises(InvalidSceneError, match="scene id must not be empty"):
        SceneMeta("")
    assert SceneMeta("s", provenance={"b": "2", "a": "1"}).provenance == (("a", "1"), ("b", "2"))
