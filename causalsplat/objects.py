"""The objects input format (DESIGN §9): a scene graph from already segmented objects.

.. code-block:: json

    {"scene_id": "kitchen", "units": "m", "up": "z",
     "objects": [{"id": 3, "label": "sink", "center": [1.0, 2.0, 0.9],
                  "size": [0.6, 0.5, 0.2],
                  "points": [[0.8, 1.8, 0.8], ...], "rgb": [231, 229, 224],
                  "attributes": {"color": "white", "affordance": ["wash hands"]}}]}

Rules:

- ``id`` (int or string, unique) becomes the entity's ``external_id`` (as text). When every
  id is a non-negative integer, it is also the entity's local id (ScanNet object 53 is
  entity 53); otherwise local ids are 0..n-1 in file order.
- The bounding box is ``center ± size/2``; the centroid is the mean of ``points`` when
  given (so it reflects where the object's mass is), else ``center``; ``point_count`` is
  the number of points (0 without points). Points themselves are not stored.
- ``attributes`` maps a key to a string or a list of strings; each value is stored with
  source ``input``.
- ``rgb`` (optional): the object's mean colour, three numbers in [0, 255]. It is stored as
  the attribute ``rgb`` = ``#rrggbb`` (source ``input``), and, unless ``attributes`` gives
  a ``color``, the basic colour term nearest to it in CIELAB
  (:func:`causalsplat.colors.names_of`) as ``color`` (source ``geometry``), as for an
  entity built from Gaussians.
- ``facing`` (optional): the direction the object's front faces (three numbers, world
  frame, with a horizontal part that is not zero), as object tables with annotated fronts
  give it (ReferIt3D's ``front_point`` minus the box centre). It is stored as the attribute
  ``facing`` = ``"x y z"`` (unit length, source ``input``); the reasoner then reads "in
  front of the toilet" and "looking at the front of the toilet, the towel on the left" from
  the toilet's own front instead of from the middle of the room. A scene built from
  Gaussians has no facing.
- ``units`` defaults to ``"m"``, ``up`` to ``"z"``.
- Relations come from the scene-graph edge builder (:mod:`causalsplat.graph.edges`),
  the same rules as for scenes built from a Gaussian field, with ``up`` as the vertical.

Every problem raises :class:`~causalsplat.errors.InputFormatError` naming the file and
the JSON path of the bad value (``objects[3].center[1]``); nothing is stored.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from causalsplat._json import JSONInputError, decode_json
from causalsplat.colors import names_of, rgb_to_hex
from causalsplat.errors import InputFormatError
from causalsplat.graph.config import EdgeConfig
from causalsplat.graph.edges import build_relations
from causalsplat.graph.errors import GraphBuildError
from graph_store import (
    Attribute,
    AttributeSource,
    Entity,
    InvalidSceneError,
    Relation,
    SceneGraph,
    SceneMeta,
)


@dataclass(frozen=True, slots=True)
class ObjectRecord:
    """One object of an objects file, validated.

    ``center``/``size``: ``(x, y, z)`` in the file's units; ``points``: ``(M, 3)`` as a tuple
    of xyz triples (possibly empty); ``attributes``: ``(key, value)`` pairs in file order.
    """

    id: int | str
    label: str
    center: tuple[float, float, float]
    size: tuple[float, float, float]
    points: tuple[tuple[float, float, float], ...]
    attributes: tuple[tuple[str, str], ...]
    rgb: tuple[float, float, float] | None = None
    facing: tuple[float, float, float] | None = None


@dataclass(frozen=True, slots=True)
class ObjectsFile:
    """A parsed objects file; ``sha256`` is the hash of the file's bytes (provenance)."""

    scene_id: str | None
    units: str
    up: str
    objects: tuple[ObjectRecord, ...]
    sha256: str
    source: str


def read_objects(path: str | Path) -> ObjectsFile:
    """Read and validate an objects file."""
    path = Path(path)
    data = path.read_bytes()
    try:
        document = decode_json(data, parse_constant=_reject_constant)
    except JSONInputError as exc:
        raise InputFormatError(f"{path}: {exc}") from None
    except ValueError as exc:
        raise InputFormatError(f"{path}: {exc}") from exc
    return parse_objects(document, source=str(path), sha256=hashlib.sha256(data).hexdigest())


def parse_objects(document: Any, *, source: str = "<objects>", sha256: str = "") -> ObjectsFile:
    """Validate an already decoded objects document."""
    where = _Where(source)
    if not isinstance(document, dict):
        raise where.error("", f"the top level must be an object, got {_kind(document)}")
    unknown = set(document) - {"scene_id", "units", "up", "objects"}
    if unknown:
        raise where.error("", f"unknown top-level keys {sorted(unknown)}")
    scene_id = document.get("scene_id")
    if scene_id is not None and (not isinstance(scene_id, str) or not scene_id):
        raise where.error("scene_id", "must be a non-empty string")
    units = _string(document.get("units", "m"), where, "units")
    up = _string(document.get("up", "z"), where, "up")
    if up not in ("x", "y", "z"):
        raise where.error("up", f"must be 'x', 'y' or 'z', got {up!r}")
    raw_objects = document.get("objects")
    if not isinstance(raw_objects, list):
        raise where.error("objects", f"must be a list, got {_kind(raw_objects)}")
    if not raw_objects:
        raise where.error("objects", "is empty: a scene needs at least one object")
    objects = tuple(_parse_object(obj, where, f"objects[{i}]") for i, obj in enumerate(raw_objects))
    seen: dict[str, int] = {}
    for i, obj in enumerate(objects):
        key = str(obj.id)
        if key in seen:
            raise where.error(
                f"objects[{i}].id", f"duplicate id {obj.id!r} (also objects[{seen[key]}])"
            )
        seen[key] = i
    return ObjectsFile(scene_id, units, up, objects, sha256, source)


def objects_graph(
    path: str | Path, *, scene_id: str | None = None, config: EdgeConfig | None = None
) -> SceneGraph:
    """The scene graph of an objects file: :func:`read_objects`, then
    :func:`objects_to_scene_graph` (every problem an :class:`InputFormatError`)."""
    return objects_to_scene_graph(read_objects(path), scene_id=scene_id, config=config)


def objects_to_scene_graph(
    objects: ObjectsFile,
    *,
    scene_id: str | None = None,
    config: EdgeConfig | None = None,
    relations: bool = True,
) -> SceneGraph:
    """Turn parsed objects into a scene graph: entities and, unless ``relations=False``,
    the spatial relations of :func:`causalsplat.graph.build_relations` (with ``config``,
    the file's ``up`` axis as the vertical)."""
    sid = scene_id or objects.scene_id
    if not sid:
        raise InputFormatError(
            f"{objects.source}: no scene id: the file has no 'scene_id' and none was given"
            " (CLI: --scene ID)"
        )
    integer_ids = all(isinstance(o.id, int) for o in objects.objects)
    entities = []
    for position, obj in enumerate(objects.objects):
        local = int(obj.id) if integer_ids else position
        half = tuple(s / 2.0 for s in obj.size)
        lo = tuple(c - h for c, h in zip(obj.center, half, strict=True))
        hi = tuple(c + h for c, h in zip(obj.center, half, strict=True))
        centroid = obj.center
        if obj.points:
            n = len(obj.points)
            centroid = tuple(math.fsum(p[axis] for p in obj.points) / n for axis in range(3))  # type: ignore[assignment]
        try:
            entities.append(
                Entity(
                    id=local,
                    category=obj.label,
                    centroid=centroid,
                    bbox_min=lo,  # type: ignore[arg-type]
                    bbox_max=hi,  # type: ignore[arg-type]
                    external_id=str(obj.id),
                    point_count=len(obj.points),
                    attributes=_entity_attributes(obj),
                )
            )
        except InvalidSceneError as exc:
            raise InputFormatError(f"{objects.source}: objects[{position}]: {exc}") from exc
    meta = SceneMeta(
        scene_id=sid,
        units=objects.units,
        up_axis=objects.up,
        source="objects",
        provenance=(("objects_sha256", objects.sha256),) if objects.sha256 else (),
    )
    edges: tuple[Relation, ...] = ()
    if relations:
        try:
            edges = build_relations(entities, config, up_axis=objects.up)
        except GraphBuildError as exc:
            raise InputFormatError(f"{objects.source}: {exc}") from exc
    try:
        return SceneGraph(meta=meta, entities=tuple(entities), relations=edges)
    except InvalidSceneError as exc:
        raise InputFormatError(f"{objects.source}: {exc}") from exc


def _entity_attributes(obj: ObjectRecord) -> tuple[Attribute, ...]:
    attrs = [Attribute(k, v, AttributeSource.INPUT) for k, v in obj.attributes]
    if obj.facing is not None and not any(k == "facing" for k, _ in obj.attributes):
        attrs.append(Attribute("facing", facing_text(obj.facing), AttributeSource.INPUT))
    if obj.rgb is None:
        return tuple(attrs)
    rgb01 = tuple(v / 255.0 for v in obj.rgb)
    if not any(k == "rgb" for k, _ in obj.attributes):
        attrs.append(Attribute("rgb", rgb_to_hex(rgb01), AttributeSource.INPUT))
    if not any(k == "color" for k, _ in obj.attributes):
        attrs.append(Attribute("color", names_of(rgb01)[0], AttributeSource.GEOMETRY))
    return tuple(attrs)


def facing_text(facing: tuple[float, float, float]) -> str:
    """A facing direction as the stored attribute value: unit length, ``"x y z"``.

    >>> facing_text((0.0, -2.0, 0.0))
    '0 -1 0'
    """
    norm = math.sqrt(math.fsum(v * v for v in facing))
    return " ".join(f"{v / norm:.6g}" for v in facing)


# -- validation helpers ------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class _Where:
    source: str

    def error(self, path: str, message: str) -> InputFormatError:
        return InputFormatError(f"{self.source}: {path + ': ' if path else ''}{message}")


def _reject_constant(name: str) -> float:
    raise ValueError(f"{name} is not a valid number (NaN and Infinity are refused)")


def _kind(value: object) -> str:
    return {dict: "an object", list: "a list", str: "a string", bool: "a boolean"}.get(
        type(value), "null" if value is None else "a number"
    )


def _string(value: object, where: _Where, path: str) -> str:
    if not isinstance(value, str) or not value.strip():
        raise where.error(path, f"must be a non-empty string, got {value!r}")
    return value


def _number(value: object, where: _Where, path: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise where.error(path, f"must be a number, got {_kind(value)}")
    number = float(value)
    if not math.isfinite(number):
        raise where.error(path, f"must be finite, got {number}")
    return number


def _triple(value: object, where: _Where, path: str) -> tuple[float, float, float]:
    if not isinstance(value, list) or len(value) != 3:
        raise where.error(path, f"must be a list of three numbers, got {value!r:.80}")
    x, y, z = (_number(v, where, f"{path}[{i}]") for i, v in enumerate(value))
    return (x, y, z)


def _parse_object(obj: object, where: _Where, path: str) -> ObjectRecord:
    if not isinstance(obj, dict):
        raise where.error(path, f"must be an object, got {_kind(obj)}")
    unknown = set(obj) - {"id", "label", "center", "size", "points", "attributes", "rgb", "facing"}
    if unknown:
        raise where.error(path, f"unknown keys {sorted(unknown)}")
    for required in ("id", "label", "center", "size"):
        if required not in obj:
            raise where.error(path, f"missing required key {required!r}")
    oid = obj["id"]
    if isinstance(oid, bool) or not isinstance(oid, int | str) or oid == "":
        raise where.error(f"{path}.id", f"must be an integer or a non-empty string, got {oid!r}")
    label = _string(obj["label"], where, f"{path}.label")
    center = _triple(obj["center"], where, f"{path}.center")
    size = _triple(obj["size"], where, f"{path}.size")
    for axis, s in zip("xyz", size, strict=True):
        if s < 0:
            raise where.error(f"{path}.size", f"{axis} extent must be >= 0, got {s}")
    raw_points = obj.get("points", [])
    if not isinstance(raw_points, list):
        raise where.error(f"{path}.points", f"must be a list, got {_kind(raw_points)}")
    points = tuple(_triple(p, where, f"{path}.points[{j}]") for j, p in enumerate(raw_points))
    rgb = None
    if obj.get("rgb") is not None:
        rgb = _triple(obj["rgb"], where, f"{path}.rgb")
        if not all(0.0 <= v <= 255.0 for v in rgb):
            raise where.error(f"{path}.rgb", f"each channel must be in [0, 255], got {list(rgb)}")
    facing = None
    if obj.get("facing") is not None:
        facing = _triple(obj["facing"], where, f"{path}.facing")
        if math.hypot(facing[0], facing[1]) == 0.0:
            raise where.error(
                f"{path}.facing", f"must point somewhere horizontally, got {list(facing)}"
            )
    attributes = _attributes(obj, where, path)
    return ObjectRecord(oid, label, center, size, points, attributes, rgb, facing)


def _attributes(obj: dict[str, Any], where: _Where, path: str) -> tuple[tuple[str, str], ...]:
    raw = obj.get("attributes", {})
    if not isinstance(raw, dict):
        raise where.error(f"{path}.attributes", f"must be an object, got {_kind(raw)}")
    pairs: list[tuple[str, str]] = []
    for key, value in raw.items():
        values = value if isinstance(value, list) else [value]
        for j, item in enumerate(values):
            if not isinstance(item, str):
                raise where.error(
                    f"{path}.attributes.{key}" + (f"[{j}]" if isinstance(value, list) else ""),
                    f"must be a string or a list of strings, got {_kind(item)}",
                )
            if (key, item) not in pairs:
                pairs.append((key, item))
    return tuple(pairs)
