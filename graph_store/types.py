"""Scene-graph types: what every stage hands to the store and gets back from it.

All types are frozen, slotted dataclasses. Constructors normalise their inputs
(lists and numpy arrays become tuples of floats, dict evidence becomes a sorted
tuple of pairs) and validate them, raising :class:`~graph_store.errors.InvalidSceneError`
with a message that names the bad value. A :class:`SceneGraph` stores its members in a
canonical order, so two graphs with the same content compare equal whatever order they
were built in, and ``load_scene(save_scene(g)) == g``.

Frames and units: coordinates are in the scene's world frame, in ``SceneMeta.units``
(metres unless said otherwise), with ``SceneMeta.up_axis`` pointing up (``z`` by default).
"""

from __future__ import annotations

import math
import unicodedata
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from datetime import datetime
from enum import StrEnum
from itertools import pairwise
from typing import Any, TypeVar

from graph_store.errors import EntityNotFound, InvalidSceneError

Vec3 = tuple[float, float, float]

#: Longest string the store accepts in a name column (ids, categories, attribute keys).
MAX_NAME_LENGTH = 512


class RelationType(StrEnum):
    """The relation vocabulary (DESIGN §6).

    Stored relations are computed when a graph is built and persisted with their
    evidence; view-dependent relations (left/right/front/behind) depend on where the
    observer stands and are computed at query time, never stored.
    """

    ABOVE = "above"
    BELOW = "below"
    SUPPORTED_BY = "supported_by"
    SUPPORTS = "supports"
    INSIDE = "inside"
    CONTAINS = "contains"
    NEAR = "near"
    NEXT_TO = "next_to"
    LEFT_OF = "left_of"
    RIGHT_OF = "right_of"
    IN_FRONT_OF = "in_front_of"
    BEHIND = "behind"

    @classmethod
    def parse(cls, name: str | RelationType) -> RelationType:
        """Return the member called ``name``; raise ``InvalidSceneError`` for unknown names."""
        if isinstance(name, RelationType):
            return name
        try:
            return cls(name)
        except ValueError:
            known = ", ".join(m.value for m in cls)
            raise InvalidSceneError(
                f"unknown relation {name!r}; expected one of: {known}"
            ) from None

    @property
    def is_stored(self) -> bool:
        """True for relations persisted in the store (not view-dependent)."""
        return self not in _VIEW_DEPENDENT

    @property
    def is_view_dependent(self) -> bool:
        """True for relations computed at query time from a viewpoint."""
        return self in _VIEW_DEPENDENT

    @property
    def inverse(self) -> RelationType:
        """The relation that holds from ``dst`` to ``src`` (itself when symmetric)."""
        return _INVERSE[self]

    @property
    def is_symmetric(self) -> bool:
        return _INVERSE[self] is self


_VIEW_DEPENDENT = frozenset(
    {
        RelationType.LEFT_OF,
        RelationType.RIGHT_OF,
        RelationType.IN_FRONT_OF,
        RelationType.BEHIND,
    }
)
_INVERSE = {
    RelationType.ABOVE: RelationType.BELOW,
    RelationType.BELOW: RelationType.ABOVE,
    RelationType.SUPPORTED_BY: RelationType.SUPPORTS,
    RelationType.SUPPORTS: RelationType.SUPPORTED_BY,
    RelationType.INSIDE: RelationType.CONTAINS,
    RelationType.CONTAINS: RelationType.INSIDE,
    RelationType.NEAR: RelationType.NEAR,
    RelationType.NEXT_TO: RelationType.NEXT_TO,
    RelationType.LEFT_OF: RelationType.RIGHT_OF,
    RelationType.RIGHT_OF: RelationType.LEFT_OF,
    RelationType.IN_FRONT_OF: RelationType.BEHIND,
    RelationType.BEHIND: RelationType.IN_FRONT_OF,
}

#: Relation types that a stored scene graph may contain.
STORED_RELATION_TYPES: tuple[RelationType, ...] = tuple(t for t in RelationType if t.is_stored)


class AttributeSource(StrEnum):
    """Where an entity attribute came from."""

    INPUT = "input"  # given by the user (objects file, labelled masks)
    MASK_VOTE = "mask-vote"  # majority vote over labelled 2D masks
    VLM = "vlm"  # a vision-language model looked at the entity's crops
    LEXICON = "lexicon"  # derived from the category through the shipped lexicon
    GEOMETRY = "geometry"  # computed from the entity's points or box


def check_text(value: object, what: str, *, allow_empty: bool = False) -> str:
    """Validate a string that goes into the store (UTF-8 encodable, no NUL, bounded)."""
    if not isinstance(value, str):
        raise InvalidSceneError(f"{what} must be a string, got {type(value).__name__}")
    if not value and not allow_empty:
        raise InvalidSceneError(f"{what} must not be empty")
    if "\x00" in value:
        raise InvalidSceneError(f"{what} {value!r} contains a NUL character")
    try:
        value.encode("utf-8")
    except UnicodeEncodeError:
        raise InvalidSceneError(f"{what} {value!r} is not valid Unicode (lone surrogate)") from None
    return value


def _check_name(value: object, what: str) -> str:
    text = check_text(value, what)
    if len(text) > MAX_NAME_LENGTH:
        raise InvalidSceneError(f"{what} is longer than {MAX_NAME_LENGTH} characters")
    return text


def check_scene_id(value: object) -> str:
    """A scene id to store: a name (:func:`check_text`, bounded) without control
    characters, since it is printed, written in file names and URLs, and typed back by
    users. Checked when a scene is saved, so that a store written before still reads."""
    text = _check_name(value, "scene id")
    bad = next((c for c in text if unicodedata.category(c) == "Cc"), None)
    if bad is not None:
        raise InvalidSceneError(f"scene id {text!r} contains the control character {bad!r}")
    return text


def check_finite(value: object, what: str) -> float:
    """Validate one real number: a finite float (bools are refused)."""
    if isinstance(value, bool):
        raise InvalidSceneError(f"{what} must be a number, got a bool")
    try:
        number = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise InvalidSceneError(f"{what} must be a number, got {value!r}") from None
    if not math.isfinite(number):
        raise InvalidSceneError(f"{what} must be finite, got {number}")
    return number


def check_vec3(value: object, what: str) -> Vec3:
    """Validate an xyz triple of finite numbers (a list, tuple or numpy array)."""
    try:
        items = list(value)  # type: ignore[call-overload]
    except TypeError:
        raise InvalidSceneError(f"{what} must be three numbers, got {value!r}") from None
    if len(items) != 3:
        raise InvalidSceneError(f"{what} must be three numbers, got {len(items)}")
    x, y, z = (check_finite(v, f"{what}[{i}]") for i, v in enumerate(items))
    return (x, y, z)


def _check_int(value: object, what: str, *, minimum: int = 0) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        try:
            import numpy as np

            if isinstance(value, np.integer):
                value = int(value)
            else:
                raise TypeError
        except TypeError:
            raise InvalidSceneError(f"{what} must be an integer, got {value!r}") from None
    if value < minimum:
        raise InvalidSceneError(f"{what} must be >= {minimum}, got {value}")
    if value >= 2**63:
        raise InvalidSceneError(f"{what} is too large: {value}")
    return int(value)


@dataclass(frozen=True, slots=True, order=True)
class Attribute:
    """One typed key/value fact about an entity, with where it came from.

    ``key`` names the kind of fact (``color``, ``material``, ``state``, ``affordance``...);
    an entity may hold several values for one key (several affordances, say).
    """

    key: str
    value: str
    source: AttributeSource = AttributeSource.INPUT

    def __post_init__(self) -> None:
        _check_name(self.key, "attribute key")
        check_text(self.value, f"value of attribute {self.key!r}")
        try:
            object.__setattr__(self, "source", AttributeSource(self.source))
        except ValueError:
            known = ", ".join(s.value for s in AttributeSource)
            raise InvalidSceneError(
                f"unknown attribute source {self.source!r}; expected one of: {known}"
            ) from None


@dataclass(frozen=True, slots=True)
class Entity:
    """A 3D entity of a scene: an object instance, or a structural element (floor, wall).

    Attributes:
        id: local id, unique within the scene (``>= 0``).
        category: the entity's category label (``"sink"``, ``"floor"``...).
        centroid: ``(x, y, z)``, world frame, scene units: mean of the entity's points.
        bbox_min: ``(x, y, z)`` lower corner of the axis-aligned bounding box.
        bbox_max: ``(x, y, z)`` upper corner; ``bbox_min <= bbox_max`` componentwise.
        external_id: the id the entity had in its input (objects file, dataset), as text.
        caption: an optional free-text description.
        point_count: how many Gaussians (or input points) belong to the entity.
        confidence: an optional score in ``[0, 1]`` from the builder.
        attributes: typed facts, kept sorted; at most one of each ``(key, value)``.
    """

    id: int
    category: str
    centroid: Vec3
    bbox_min: Vec3
    bbox_max: Vec3
    external_id: str | None = None
    caption: str | None = None
    point_count: int = 0
    confidence: float | None = None
    attributes: tuple[Attribute, ...] = ()

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "id", _check_int(self.id, "entity id"))
        where = f"entity {self.id!r}"
        _check_name(self.category, f"category of {where}")
        set_(self, "centroid", check_vec3(self.centroid, f"centroid of {where}"))
        lo = check_vec3(self.bbox_min, f"bbox_min of {where}")
        hi = check_vec3(self.bbox_max, f"bbox_max of {where}")
        for axis, low, high in zip("xyz", lo, hi, strict=True):
            if low > high:
                raise InvalidSceneError(f"bbox of {where} has min {axis}={low} > max {axis}={high}")
        set_(self, "bbox_min", lo)
        set_(self, "bbox_max", hi)
        if self.external_id is not None:
            set_(self, "external_id", _check_name(self.external_id, f"external id of {where}"))
        if self.caption is not None:
            check_text(self.caption, f"caption of {where}", allow_empty=True)
        set_(self, "point_count", _check_int(self.point_count, f"point_count of {where}"))
        if self.confidence is not None:
            c = check_finite(self.confidence, f"confidence of {where}")
            if not 0.0 <= c <= 1.0:
                raise InvalidSceneError(f"confidence of {where} must be in [0, 1], got {c}")
            set_(self, "confidence", c)
        attrs = tuple(sorted(self.attributes))
        for a in attrs:
            if not isinstance(a, Attribute):
                raise InvalidSceneError(f"attributes of {where} must be Attribute, got {a!r}")
        for a, b in pairwise(attrs):
            if (a.key, a.value) == (b.key, b.value):
                raise InvalidSceneError(
                    f"{where} has attribute {a.key}={a.value!r} twice ({a.source}, {b.source})"
                )
        set_(self, "attributes", attrs)

    @property
    def size(self) -> Vec3:
        """Extent of the bounding box along x, y, z."""
        lo, hi = self.bbox_min, self.bbox_max
        return (hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2])

    @property
    def volume(self) -> float:
        sx, sy, sz = self.size
        return sx * sy * sz

    def attribute_values(self, key: str) -> tuple[str, ...]:
        """All values of one attribute key, in sorted order."""
        return tuple(a.value for a in self.attributes if a.key == key)


def _normalise_evidence(value: object, where: str) -> tuple[tuple[str, float], ...]:
    items: Iterable[Any] = value.items() if isinstance(value, Mapping) else value  # type: ignore[assignment]
    pairs: dict[str, float] = {}
    for item in items:
        try:
            name, number = item
        except (TypeError, ValueError):
            raise InvalidSceneError(f"evidence of {where} must be name/number pairs") from None
        _check_name(name, f"evidence name of {where}")
        if name in pairs:
            raise InvalidSceneError(f"evidence of {where} names {name!r} twice")
        pairs[name] = check_finite(number, f"evidence {name!r} of {where}")
    return tuple(sorted(pairs.items()))


@dataclass(frozen=True, slots=True, order=True)
class Relation:
    """A directed, typed edge ``src --type--> dst`` ("src is <type> dst").

    ``Relation(3, 7, "above")`` reads "entity 3 is above entity 7". ``evidence`` holds the
    numbers the edge rule measured (``distance``, ``vertical_ratio``, ``overlap``...); pass
    a dict, it is kept as a sorted tuple of ``(name, value)`` pairs.
    """

    src: int
    dst: int
    type: RelationType
    evidence: tuple[tuple[str, float], ...] = field(default=(), compare=True)

    def __post_init__(self) -> None:
        object.__setattr__(self, "src", _check_int(self.src, "relation src"))
        object.__setattr__(self, "dst", _check_int(self.dst, "relation dst"))
        rel = RelationType.parse(self.type)
        object.__setattr__(self, "type", rel)
        where = f"relation {self.src} {rel.value} {self.dst}"
        if self.src == self.dst:
            raise InvalidSceneError(f"{where} relates an entity to itself")
        object.__setattr__(self, "evidence", _normalise_evidence(self.evidence, where))

    @property
    def evidence_dict(self) -> dict[str, float]:
        return dict(self.evidence)


@dataclass(frozen=True, slots=True, order=True)
class View:
    """A camera view the scene was built from (provenance of masks).

    ``id`` is local to the scene; ``name`` is the image stem on disk.
    """

    id: int
    name: str
    width: int
    height: int

    def __post_init__(self) -> None:
        object.__setattr__(self, "id", _check_int(self.id, "view id"))
        _check_name(self.name, f"name of view {self.id}")
        object.__setattr__(
            self, "width", _check_int(self.width, f"width of view {self.id}", minimum=1)
        )
        object.__setattr__(
            self, "height", _check_int(self.height, f"height of view {self.id}", minimum=1)
        )


@dataclass(frozen=True, slots=True, order=True)
class MaskRecord:
    """One 2D mask of one view and the entity it was assigned to (``None``: noise)."""

    view: int
    index: int
    entity: int | None = None
    label: str | None = None
    score: float | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "view", _check_int(self.view, "mask view"))
        object.__setattr__(self, "index", _check_int(self.index, "mask index"))
        where = f"mask {self.index} of view {self.view}"
        if self.entity is not None:
            object.__setattr__(self, "entity", _check_int(self.entity, f"entity of {where}"))
        if self.label is not None:
            check_text(self.label, f"label of {where}")
        if self.score is not None:
            object.__setattr__(self, "score", check_finite(self.score, f"score of {where}"))


@dataclass(frozen=True, slots=True)
class SceneMeta:
    """Scene-level metadata.

    Attributes:
        scene_id: the id users see (``"scene0000_00"``).
        name: an optional human-readable name.
        units: length unit of all coordinates (``"m"``, ``"mm"``...).
        up_axis: ``"x"``, ``"y"`` or ``"z"``: which world axis points up.
        source: what produced the graph (``"objects"``, ``"build"``, ``"rdf"``...).
        config_hash: hash of the builder configuration, ``None`` when not built.
        provenance: ``(name, value)`` pairs such as input file hashes; a dict is accepted.
        created_at: set by the store when saved; not part of equality.
    """

    scene_id: str
    name: str | None = None
    units: str = "m"
    up_axis: str = "z"
    source: str = "objects"
    config_hash: str | None = None
    provenance: tuple[tuple[str, str], ...] = ()
    created_at: datetime | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        _check_name(self.scene_id, "scene id")
        if self.name is not None:
            check_text(self.name, f"name of scene {self.scene_id!r}", allow_empty=True)
        _check_name(self.units, "units")
        if self.up_axis not in ("x", "y", "z"):
            raise InvalidSceneError(f"up axis must be 'x', 'y' or 'z', got {self.up_axis!r}")
        _check_name(self.source, "scene source")
        if self.config_hash is not None:
            _check_name(self.config_hash, "config hash")
        prov = self.provenance
        pairs = prov.items() if isinstance(prov, Mapping) else prov
        checked: dict[str, str] = {}
        for item in pairs:
            try:
                key, value = item
            except (TypeError, ValueError):
                raise InvalidSceneError("provenance must be name/value pairs") from None
            _check_name(key, "provenance name")
            check_text(value, f"provenance {key!r}", allow_empty=True)
            if key in checked:
                raise InvalidSceneError(f"provenance names {key!r} twice")
            checked[key] = value
        object.__setattr__(self, "provenance", tuple(sorted(checked.items())))


@dataclass(frozen=True, slots=True)
class SceneGraph:
    """A typed 3D scene graph: entities, stored relations, and their provenance.

    Members are kept in canonical order (entities by id, relations by
    ``(src, type, dst)``, views by id, masks by ``(view, index)``). Construction
    validates the whole graph: unique entity ids and external ids, relations between
    existing entities with stored relation types and no duplicates, masks on existing
    views assigned to existing entities.
    """

    meta: SceneMeta
    entities: tuple[Entity, ...] = ()
    relations: tuple[Relation, ...] = ()
    views: tuple[View, ...] = ()
    masks: tuple[MaskRecord, ...] = ()
    _by_id: dict[int, Entity] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        if not isinstance(self.meta, SceneMeta):
            raise InvalidSceneError(f"meta must be a SceneMeta, got {type(self.meta).__name__}")
        entities = tuple(sorted(self.entities, key=_entity_key))
        by_id: dict[int, Entity] = {}
        external: set[str] = set()
        for e in entities:
            if not isinstance(e, Entity):
                raise InvalidSceneError(f"entities must be Entity, got {type(e).__name__}")
            if e.id in by_id:
                raise InvalidSceneError(f"duplicate entity id {e.id}")
            by_id[e.id] = e
            if e.external_id is not None:
                if e.external_id in external:
                    raise InvalidSceneError(f"duplicate external id {e.external_id!r}")
                external.add(e.external_id)
        relations = tuple(sorted(self.relations, key=_relation_key))
        previous: tuple[int, str, int] | None = None
        for r in relations:
            if not isinstance(r, Relation):
                raise InvalidSceneError(f"relations must be Relation, got {type(r).__name__}")
            key = _relation_key(r)
            if key == previous:
                raise InvalidSceneError(f"duplicate relation {r.src} {r.type.value} {r.dst}")
            previous = key
            if not r.type.is_stored:
                raise InvalidSceneError(
                    f"relation {r.src} {r.type.value} {r.dst}: {r.type.value!r} is view-dependent"
                    " and computed at query time; it cannot be stored"
                )
            for end in (r.src, r.dst):
                if end not in by_id:
                    raise InvalidSceneError(
                        f"relation {r.src} {r.type.value} {r.dst} refers to missing entity {end}"
                    )
        views = tuple(sorted(self.views))
        view_ids = {v.id for v in views}
        if len(view_ids) != len(views):
            raise InvalidSceneError("duplicate view id")
        masks = tuple(sorted(self.masks, key=lambda m: (m.view, m.index)))
        seen_masks: set[tuple[int, int]] = set()
        for m in masks:
            if (m.view, m.index) in seen_masks:
                raise InvalidSceneError(f"duplicate mask {m.index} of view {m.view}")
            seen_masks.add((m.view, m.index))
            if m.view not in view_ids:
                raise InvalidSceneError(f"mask {m.index} refers to missing view {m.view}")
            if m.entity is not None and m.entity not in by_id:
                raise InvalidSceneError(
                    f"mask {m.index} of view {m.view} refers to missing entity {m.entity}"
                )
        set_(self, "entities", entities)
        set_(self, "relations", relations)
        set_(self, "views", views)
        set_(self, "masks", masks)
        set_(self, "_by_id", by_id)

    @property
    def scene_id(self) -> str:
        return self.meta.scene_id

    def get_entity(self, entity_id: int) -> Entity:
        """The entity with this id; raises :class:`EntityNotFound` when missing."""
        try:
            return self._by_id[entity_id]
        except KeyError:
            raise EntityNotFound(f"scene {self.scene_id!r} has no entity {entity_id!r}") from None

    def find_entity(self, entity_id: int) -> Entity | None:
        """The entity with this id, or ``None``."""
        return self._by_id.get(entity_id)

    def has_entity(self, entity_id: int) -> bool:
        return entity_id in self._by_id

    def relations_of(self, rel: RelationType | str) -> tuple[Relation, ...]:
        """All relations of one type."""
        wanted = RelationType.parse(rel)
        return tuple(r for r in self.relations if r.type is wanted)


def _trusted(cls: type[_T], **fields: Any) -> _T:
    """Build a frozen dataclass without validation, from values the store validated on write.

    Only :mod:`graph_store.repository` uses this, for rows it reads back: the database
    enforces types, NOT NULL, enums and references, and every value was checked when written.
    """
    obj = object.__new__(cls)
    for name, value in fields.items():
        object.__setattr__(obj, name, value)
    return obj


def trusted_entity(
    id: int,
    category: str,
    centroid: Vec3,
    bbox_min: Vec3,
    bbox_max: Vec3,
    external_id: str | None,
    caption: str | None,
    point_count: int,
    confidence: float | None,
    attributes: tuple[Attribute, ...],
) -> Entity:
    return _trusted(
        Entity, id=id, category=category, centroid=centroid, bbox_min=bbox_min,
        bbox_max=bbox_max, external_id=external_id, caption=caption, point_count=point_count,
        confidence=confidence, attributes=tuple(sorted(attributes)),
    )  # fmt: skip


def trusted_relation(src: int, dst: int, type: str, evidence: Mapping[str, float]) -> Relation:
    return _trusted(
        Relation,
        src=src,
        dst=dst,
        type=RelationType(type),
        evidence=tuple(sorted(evidence.items())),
    )


def trusted_scene_graph(
    meta: SceneMeta,
    entities: Iterable[Entity],
    relations: Iterable[Relation],
    views: Iterable[View],
    masks: Iterable[MaskRecord],
) -> SceneGraph:
    """A scene graph from trusted members, put in canonical order."""
    ents = tuple(sorted(entities, key=lambda e: e.id))
    return _trusted(
        SceneGraph,
        meta=meta,
        entities=ents,
        relations=tuple(sorted(relations, key=lambda r: (r.src, r.type.value, r.dst))),
        views=tuple(sorted(views)),
        masks=tuple(sorted(masks, key=lambda m: (m.view, m.index))),
        _by_id={e.id: e for e in ents},
    )


_T = TypeVar("_T")


def _entity_key(e: Entity) -> int:
    if not isinstance(e, Entity):
        raise InvalidSceneError(f"entities must be Entity, got {type(e).__name__}")
    return e.id


def _relation_key(r: Relation) -> tuple[int, str, int]:
    if not isinstance(r, Relation):
        raise InvalidSceneError(f"relations must be Relation, got {type(r).__name__}")
    return (r.src, r.type.value, r.dst)
