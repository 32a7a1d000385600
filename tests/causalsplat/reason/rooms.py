"""Rooms for reasoner tests, written as objects documents (the ReferIt3D setting: labelled
boxes, our edges)."""

from __future__ import annotations

from typing import Any

from causalsplat.objects import objects_to_scene_graph, parse_objects
from causalsplat.reason import SceneContext

#: ``(id, label, centre, size)``, metres, optionally with more object fields (``{"rgb":
#: [r, g, b]}``).
Box = (
    tuple[int, str, tuple[float, float, float], tuple[float, float, float]]
    | tuple[int, str, tuple[float, float, float], tuple[float, float, float], dict[str, Any]]
)


def room_of_boxes(objects: list[Box]) -> SceneContext:
    """A scene ``room`` holding one labelled box per object."""
    doc: dict[str, Any] = {
        "scene_id": "room",
        "objects": [
            {
                "id": o[0],
                "label": o[1],
                "center": list(o[2]),
                "size": list(o[3]),
                **(o[4] if len(o) > 4 else {}),
            }  # type: ignore[misc]
            for o in objects
        ],
    }
    return SceneContext(objects_to_scene_graph(parse_objects(doc)))
