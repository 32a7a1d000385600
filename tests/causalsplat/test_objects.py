"""The objects input format: parsing, validation messages, and the real ScanNet table."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from causalsplat import InputFormatError, open_store
from causalsplat.graph import EdgeConfig, build_relations
from causalsplat.objects import objects_to_scene_graph, parse_objects, read_objects
from tests.conftest import shared_data_path


def write(tmp_path: Path, document: Any, name: str = "objects.json") -> Path:
    path = tmp_path / name
    path.write_text(document if isinstance(document, str) else json.dumps(document))
    return path


KITCHEN = {
    "scene_id": "kitchen",
    "objects": [
        {"id": 4, "label": "sink", "center": [1, 2, 0.9], "size": [0.6, 0.4, 0.2],
         "attributes": {"color": "white", "affordance": ["wash hands", "rinse"]}},
        {"id": 7, "label": "towel", "center": [1.5, 2, 1.0], "size": [0.2, 0.05, 0.4],
         "points": [[1.5, 2.0, 0.9], [1.5, 2.0, 1.2], [1.5, 2.0, 1.2]]},
    ],
}  # fmt: skip


def test_objects_become_entities_with_input_ids(tmp_path: Path) -> None:
    graph = objects_to_scene_graph(read_objects(write(tmp_path, KITCHEN)))
    sink, towel = graph.entities
    assert (sink.id, sink.external_id, sink.category) == (4, "4", "sink")
    assert sink.bbox_min == pytest.approx((0.7, 1.8, 0.8)) and sink.bbox_max == pytest.approx(
        (1.3, 2.2, 1.0)
    )
    assert sink.centroid == (1.0, 2.0, 0.9) and sink.point_count == 0
    assert sink.attribute_values("affordance") == ("rinse", "wash hands")
    assert towel.centroid == pytest.approx((1.5, 2.0, 1.1)) and towel.point_count == 3
    assert graph.meta.units == "m" and graph.meta.up_axis == "z"
    assert dict(graph.meta.provenance)["objects_sha256"]


def test_objects_get_relations_from_the_edge_builder(tmp_path: Path) -> None:
    objects = read_objects(write(tmp_path, KITCHEN))
    graph = objects_to_scene_graph(objects)
    # Centroids 0.539 apart < 1.5 x (0.361 + 0.103) footprint half-diagonals, z ranges
    # overlap by 0.2; the towel is beside the sink, neither above nor on it.
    assert {(r.src, r.type.value, r.dst) for r in graph.relations} == {
        (4, "near", 7), (7, "near", 4), (4, "next_to", 7), (7, "next_to", 4)
    }  # fmt: skip
    near = next(r for r in graph.relations if r.type.value == "near")
    assert near.evidence_dict["distance"] == pytest.approx(0.29**0.5)
    assert graph.relations == build_relations(graph.entities)
    assert objects_to_scene_graph(objects, relations=False).relations == ()
    strict = objects_to_scene_graph(objects, config=EdgeConfig(near_factor=1.0))
    assert strict.relations == ()


def test_up_axis_of_the_file_is_the_vertical(tmp_path: Path) -> None:
    stack = {"objects": [
        {"id": 1, "label": "table", "center": [0, 0.4, 0], "size": [1, 0.8, 1]},
        {"id": 2, "label": "cup", "center": [0, 0.85, 0], "size": [0.1, 0.1, 0.1]},
    ]}  # fmt: skip
    y_up = objects_to_scene_graph(parse_objects({**stack, "up": "y"}), scene_id="s")
    kinds = {(r.src, r.type.value, r.dst) for r in y_up.relations}
    assert {(2, "supported_by", 1), (2, "above", 1), (1, "below", 2)} <= kinds
    z_up = objects_to_scene_graph(parse_objects(stack), scene_id="s")
    assert not {k for k in (r.type.value for r in z_up.relations) if k == "supported_by"}


def test_string_ids_get_positional_local_ids() -> None:
    doc = {"objects": [one(id="b", label="x")["objects"][0], one(id=3, label="y")["objects"][0]]}
    graph = objects_to_scene_graph(parse_objects(doc), scene_id="s")
    assert [(e.id, e.external_id) for e in graph.entities] == [(0, "b"), (1, "3")]


def one(**changes: Any) -> dict[str, Any]:
    """A document with one valid object, changed by ``changes`` (``None`` drops a key)."""
    obj: dict[str, Any] = {"id": 1, "label": "a", "center": [0, 0, 0], "size": [1, 1, 1]}
    obj.update(changes)
    return {"objects": [{k: v for k, v in obj.items() if v is not None}]}


NAN_CENTER = '{"objects": [{"id": 1, "label": "a", "center": [NaN, 0, 0], "size": [1, 1, 1]}]}'
BAD = [
    ("{not json", "not valid JSON"),
    (NAN_CENTER, "NaN"),
    (NAN_CENTER.replace("NaN", "Infinity"), "Infinity"),
    ([], "top level must be an object"),
    ({"objects": {}}, "objects: must be a list"),
    (one(label=None), r"objects\[0\]: missing required key 'label'"),
    (one(center=[0, 0]), r"objects\[0\].center: must be a list of three"),
    (one(center=[0, "x", 0]), r"objects\[0\].center\[1\]: must be a number"),
    (one(size=[1, -1, 1]), r"y extent must be >= 0"),
    ({"objects": one()["objects"] * 2}, r"objects\[1\].id: duplicate id 1"),
    (one(id=True), "must be an integer or a non-empty string"),
    (one(attributes={"color": 3}), r"attributes.color: must be a string"),
    (one(colour="red"), "unknown keys"),
    (one(points=[[0, 0]]), r"points\[0\]: must be a list of three"),
    (one(rgb=[0, 0]), r"objects\[0\].rgb: must be a list of three"),
    (one(rgb=[0, 256, 0]), r"objects\[0\].rgb: each channel must be in \[0, 255\]"),
    (one(rgb=[-1, 0, 0]), r"objects\[0\].rgb: each channel must be in \[0, 255\]"),
    (one(rgb="#ffffff"), r"objects\[0\].rgb: must be a list of three"),
    (one(facing=[0, 1]), r"objects\[0\].facing: must be a list of three"),
    (one(facing=[0, 0, 1]), r"objects\[0\].facing: must point somewhere horizontally"),
    (one(facing=[0, "n", 0]), r"objects\[0\].facing\[1\]: must be a number"),
]


@pytest.mark.parametrize(("document", "message"), BAD)
def test_malformed_objects_files_raise_input_format_error(
    tmp_path: Path, document: Any, message: str
) -> None:
    path = write(tmp_path, document)
    with pytest.raises(InputFormatError, match=message) as info:
        objects_to_scene_graph(read_objects(path), scene_id="s")
    assert str(path) in str(info.value)


def test_missing_scene_id_is_reported(tmp_path: Path) -> None:
    doc = {"objects": KITCHEN["objects"]}
    with pytest.raises(InputFormatError, match="no scene id"):
        objects_to_scene_graph(read_objects(write(tmp_path, doc)))


def test_bad_file_writes_nothing(tmp_path: Path) -> None:
    with open_store(f"sqlite:///{tmp_path / 's.db'}") as store:
        store.ingest_objects(write(tmp_path, KITCHEN))
        bad = {"scene_id": "other", "objects": [*KITCHEN["objects"], {"id": 9, "label": "x"}]}
        with pytest.raises(InputFormatError):
            store.ingest_objects(write(tmp_path, bad, "bad.json"))
        assert [s.scene_id for s in store.scenes()] == ["kitchen"]


def scannet_objects_document() -> dict[str, Any]:
    """The real object table of scene0000_00 in the objects format (AABB centre and size)."""
    path = shared_data_path("scannet_scene0000_00", "language_gt", "objects_info_scene0000_00.json")
    table = json.loads(path.read_text())
    return {
        "scene_id": "scene0000_00",
        "units": "m",
        "up": "z",
        "objects": [
            {"id": o["id"], "label": o["label"], "center": o["center_position"], "size": o["size"]}
            for o in table["objects"]
        ],
    }


@pytest.mark.shared_data
def test_ingest_real_scannet_object_table(tmp_path: Path) -> None:
    document = scannet_objects_document()
    path = write(tmp_path, document)
    with open_store(f"sqlite:///{tmp_path / 's.db'}") as store:
        scene = store.ingest_objects(path)
        graph = store.scene("scene0000_00").graph
    assert scene.id == "scene0000_00"
    assert len(graph.entities) == 67
    assert [e.external_id for e in graph.entities] == [str(i) for i in range(67)]
    by_id = {e.id: e for e in graph.entities}
    labels = {o["id"]: o["label"] for o in document["objects"]}
    assert all(by_id[i].category == labels[i] for i in range(67))
    assert by_id[53].category == "toaster" and by_id[2].category == "table"
    window = by_id[0]  # the table's extension is [0.609, 3.405, 1.570, 2.354, 3.637, 2.143]
    assert window.bbox_min == pytest.approx((0.6091, 3.4048, 1.5704), abs=1e-4)
    assert window.bbox_max == pytest.approx((2.3535, 3.6367, 2.1427), abs=1e-4)


def test_rgb_is_stored_with_the_nearest_colour_term() -> None:
    doc = one(rgb=[230, 228, 222])
    doc["objects"].append({"id": 2, "label": "b", "center": [3, 0, 0], "size": [1, 1, 1],
                           "rgb": [120, 80, 50], "attributes": {"color": "walnut"}})  # fmt: skip
    graph = objects_to_scene_graph(parse_objects(doc), scene_id="s")
    first, second = (
        {(a.key, a.value, a.source.value) for a in e.attributes} for e in graph.entities
    )
    assert first == {("rgb", "#e6e4de", "input"), ("color", "white", "geometry")}
    # a colour name the file gives stands; the measured colour is kept beside it
    assert second == {("rgb", "#785032", "input"), ("color", "walnut", "input")}


def test_facing_is_stored_as_a_unit_direction_and_read_back(tmp_path: Path) -> None:
    from causalsplat.reason import SceneContext

    doc = one(facing=[0.0, -3.0, 4.0])
    doc["scene_id"] = "s"
    doc["objects"].append({"id": 2, "label": "b", "center": [3, 0, 0], "size": [1, 1, 1],
                           "facing": [1, 1, 0], "attributes": {"facing": "0 1 0"}})  # fmt: skip
    with open_store(f"sqlite:///{tmp_path / 's.db'}") as store:
        store.ingest_objects(write(tmp_path, doc))
        graph = store.scene("s").graph
    first, second = ({(a.key, a.value) for a in e.attributes} for e in graph.entities)
    assert first == {("facing", "0 -0.6 0.8")}
    assert second == {("facing", "0 1 0")}  # a facing the file's attributes give stands
    ctx = SceneContext(graph)
    assert ctx.facing(1) == (0.0, -1.0)  # the horizontal part, unit length
    assert ctx.facing(2) == (0.0, 1.0)


@pytest.mark.parametrize("value", ["north", "0 0 1", "1 2", "nan 0 0", "inf 1 0"])
def test_an_unusable_stored_facing_is_no_facing(value: str) -> None:
    from causalsplat.reason import SceneContext

    doc = one(attributes={"facing": value})
    ctx = SceneContext(objects_to_scene_graph(parse_objects(doc), scene_id="s"))
    assert ctx.facing(1) is None


def test_a_bad_file_creates_no_store(tmp_path: Path) -> None:
    from click.testing import CliRunner

    from causalsplat.cli import cli

    path = write(tmp_path, one(rgb=[1, 2, 300]))
    db = tmp_path / "new.db"
    result = CliRunner().invoke(cli, ["ingest-objects", str(path), "--scene", "s",
                                      "--db", f"sqlite:///{db}"])  # fmt: skip
    assert result.exit_code == 1 and "rgb: each channel must be in [0, 255]" in result.output
    assert "Traceback" not in result.output and not db.exists()
