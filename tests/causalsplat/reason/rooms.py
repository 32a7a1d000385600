"""Rooms for reasoner tests, written as objects documents (the ReferIt3D setting: labelled
boxes, our edges)."""

from __future__ import annotations

from typing import Any

from causalsplat.objects import objects_to_scene_graph, parse_objects
from causalsplat.reason import SceneContext

#: ``(id, label, centre, size)``, metres.
Box = tuple[int, str, tuple[float, float, float], tuple[float, float, float]]


def room_of_boxes(objects: list[Box]) -> SceneContext:
    """A scene ``room`` holding one labelled box per object."""
    doc: dict[str, Any] = {
        "scene_id": "room",
        "objects": [
            {"id": i, "label": label, "center": list(c), "size": list(s)}
            for i, label, c, s in objects
        ],
    }
    return SceneContext(objects_to_scene_graph(parse_objects(doc)))
