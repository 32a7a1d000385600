"""JSON documents of scene-graph members: the forms the JSON API and ``--json`` outputs share.

Every function returns plain ``dict`` / ``list`` / ``str`` / ``int`` / ``float`` / ``None``
values, ready for :func:`json.dumps`, and loses nothing a reader of the graph needs:

>>> from graph_store.types import Attribute, Entity, Relation
>>> e = Entity(3, "sink", (1.0, 2.0, 0.9), (0.7, 1.8, 0.8), (1.3, 2.2, 1.0),
...            external_id="3", attributes=(Attribute("color", "white"),))
>>> doc = entity_document(e)
>>> doc["id"], doc["category"], doc["color"], doc["bbox_max"]
(3, 'sink', 'white', [1.3, 2.2, 1.0])
>>> doc["attributes"]
[{'key': 'color', 'value': 'white', 'source': 'input'}]
>>> relation_document(Relation(3, 7, "above", {"distance": 0.1}))
{'subject': 3, 'predicate': 'above', 'object': 7, 'evidence': {'distance': 0.1}}
"""

from __future__ import annotations

from typing import Any

from graph_store.repository import SceneSummary
from graph_store.types import Entity, Relation, SceneGraph, SceneMeta


def entity_document(entity: Entity) -> dict[str, Any]:
    """``{"id", "external_id", "category", "caption", "centroid", "bbox_min", "bbox_max",
    "point_count", "confidence", "color", "attributes"}``.

    Coordinates are ``[x, y, z]`` lists in the scene's world frame and units; ``color`` is
    the first ``color`` attribute (sorted order) or ``None``; ``attributes`` lists every
    attribute as ``{"key", "value", "source"}``.
    """
    colors = entity.attribute_values("color")
    return {
        "id": entity.id,
        "external_id": entity.external_id,
        "category": entity.category,
        "caption": entity.caption,
        "centroid": list(entity.centroid),
        "bbox_min": list(entity.bbox_min),
        "bbox_max": list(entity.bbox_max),
        "point_count": entity.point_count,
        "confidence": entity.confidence,
        "color": colors[0] if colors else None,
        "attributes": [
            {"key": a.key, "value": a.value, "source": a.source.value} for a in entity.attributes
        ],
    }


def relation_document(relation: Relation) -> dict[str, Any]:
    """``{"subject", "predicate", "object", "evidence"}``: "subject is <predicate> object",
    entity ids, the relation type's name, and the measured numbers by name."""
    return {
        "subject": relation.src,
        "predicate": relation.type.value,
        "object": relation.dst,
        "evidence": dict(relation.evidence),
    }


def meta_document(meta: SceneMeta) -> dict[str, Any]:
    """``{"scene_id", "name", "units", "up_axis", "source", "config_hash", "provenance",
    "created_at"}`` (``created_at``: ISO 8601 text, or ``None`` for an unsaved graph)."""
    return {
        "scene_id": meta.scene_id,
        "name": meta.name,
        "units": meta.units,
        "up_axis": meta.up_axis,
        "source": meta.source,
        "config_hash": meta.config_hash,
        "provenance": dict(meta.provenance),
        "created_at": None if meta.created_at is None else meta.created_at.isoformat(),
    }


def scene_document(graph: SceneGraph) -> dict[str, Any]:
    """``{"scene_id", "meta", "entities", "relations"}`` of a whole scene graph."""
    return {
        "scene_id": graph.scene_id,
        "meta": meta_document(graph.meta),
        "entities": [entity_document(e) for e in graph.entities],
        "relations": [relation_document(r) for r in graph.relations],
    }


def summary_document(summary: SceneSummary) -> dict[str, Any]:
    """One row of a scene listing: ``{"scene_id", "name", "entities", "relations",
    "source", "units", "up_axis", "created_at", "config_hash"}``."""
    return {
        "scene_id": summary.scene_id,
        "name": summary.name,
        "entities": summary.entity_count,
        "relations": summary.relation_count,
        "source": summary.source,
        "units": summary.units,
        "up_axis": summary.up_axis,
        "created_at": summary.created_at.isoformat(),
        "config_hash": summary.config_hash,
    }
