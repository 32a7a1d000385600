"""Scenes for the reasoner tests: a hand-made room and the synthetic tiny scene."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from causalsplat import Scene, Store, open_store
from causalsplat.objects import objects_to_scene_graph, parse_objects
from causalsplat.reason import SceneContext
from graph_store import SceneGraph

#: A room (metres, z up): id -> (label, min corner, max corner, attributes).
ROOM = {
    0: ("floor", (0.0, 0.0, -0.05), (6.0, 4.0, 0.0), {}),
    1: ("table", (2.0, 1.0, 0.0), (3.2, 2.0, 0.75), {"color": "brown"}),
    2: ("cup", (2.2, 1.2, 0.75), (2.3, 1.3, 0.85), {"color": "red"}),
    3: ("box", (2.8, 1.5, 0.75), (3.0, 1.8, 0.95), {"color": "white"}),
    4: ("cup", (2.85, 1.6, 0.95), (2.95, 1.7, 1.05), {"color": "blue"}),
    5: ("chair", (1.0, 1.2, 0.0), (1.5, 1.7, 0.9), {}),
    6: ("chair", (3.6, 1.2, 0.0), (4.1, 1.7, 0.9), {}),
    7: ("chair", (5.1, 2.9, 0.0), (5.7, 3.5, 1.1), {}),
    8: ("door", (0.0, 3.9, 0.0), (1.0, 4.0, 2.1), {}),
    9: ("lamp", (5.3, 0.2, 0.0), (5.6, 0.5, 1.6), {}),
    10: ("couch", (0.2, 0.2, 0.0), (2.0, 1.0, 0.8), {}),
}


def room_document() -> dict[str, object]:
    objects = []
    for oid, (label, lo, hi, attrs) in ROOM.items():
        objects.append(
            {
                "id": oid,
                "label": label,
                "center": [(a + b) / 2 for a, b in zip(lo, hi, strict=True)],
                "size": [b - a for a, b in zip(lo, hi, strict=True)],
                "attributes": attrs,
            }
        )
    return {"scene_id": "room", "units": "m", "up": "z", "objects": objects}


@pytest.fixture(scope="session")
def room_graph() -> SceneGraph:
    return objects_to_scene_graph(parse_objects(room_document()))


@pytest.fixture
def room(room_graph: SceneGraph) -> SceneContext:
    return SceneContext(room_graph)


@pytest.fixture(scope="session")
def tiny_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from causalsplat.synth import synth_scene

    out = tmp_path_factory.mktemp("synth") / "tiny0"
    synth_scene("tiny", 0, out)
    return out


@pytest.fixture
def tiny_store(tiny_dir: Path, tmp_path: Path) -> Iterator[Store]:
    with open_store(f"sqlite:///{tmp_path / 'tiny.db'}") as store:
        store.ingest_objects(tiny_dir / "objects.json")
        yield store


@pytest.fixture
def tiny_scene(tiny_store: Store) -> Scene:
    return tiny_store.scene("synth-tiny-0")
