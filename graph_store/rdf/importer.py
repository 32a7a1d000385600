"""Read scene graphs back from RDF (the mapping written by :mod:`graph_store.rdf.export`).

The reader goes by classes and properties, not by IRI shapes: scenes are the
``csg:Scene`` nodes, entities the ``csg:Entity`` nodes with ``csg:inScene``, relations the
direct ``csg:<type>`` triples between entities (with evidence from matching
``csg:RelationAssertion`` nodes), views and masks likewise. Redundant statements
(``rdfs:label``, ``bot:containsElement``, the GeoSPARQL point) are not read back. Terms
outside the ``csg:`` namespace are ignored; unknown ``csg:`` terms are refused.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path

from graph_store.errors import InvalidSceneError, RDFFormatError
from graph_store.rdf._index import TripleIndex, short, show
from graph_store.rdf._parse import Triple, parse_triples
from graph_store.rdf.namespace import CSG
from graph_store.types import (
    Attribute,
    AttributeSource,
    Entity,
    MaskRecord,
    Relation,
    RelationType,
    SceneGraph,
    SceneMeta,
    View,
)

_SUFFIX_FORMATS = {
    ".ttl": "turtle",
    ".turtle": "turtle",
    ".nt": "ntriples",
    ".jsonld": "jsonld",
    ".json": "jsonld",
}
_RELATIONS = {str(CSG[t.value]): t for t in RelationType}
_C = {name: str(CSG[name]) for name in CSG.__annotations__ if not name.startswith("_")}


def read_scenes(
    source: str | Path | bytes, format: str | None = None, *, engine: str | None = None
) -> list[SceneGraph]:
    """Scene graphs from an RDF document, sorted by scene id.

    ``source``: a file path (``Path``, or a ``str`` naming a file), or the document itself
    as ``bytes``, or as a ``str`` that is empty, spans several lines, or starts like RDF
    (``@``, ``<``, ``{``, ``[``, ``#``, ``_:``, ``PREFIX``/``BASE``).
    ``format``: ``turtle``, ``ntriples`` or ``jsonld``; guessed from the file suffix
    (``.ttl``, ``.nt``, ``.jsonld``, ``.json``) or, for a document, from its first character.
    ``engine``: the parser (``"oxigraph"`` or ``"rdflib"``; default pyoxigraph when installed).

    Raises :class:`RDFFormatError` for malformed RDF and for documents that do not describe
    valid scenes (missing or repeated properties, wrong literal types, non-finite numbers,
    unknown ``csg:`` terms), naming the scene, the node and the property.
    """
    data, fmt = _load(source, format)
    return scenes_from_triples(parse_triples(data, fmt, engine=engine))


def _looks_like_document(text: str) -> bool:
    head = text.lstrip()[:6].upper()
    return (
        not text
        or "\n" in text
        or head[:1] in ("@", "<", "{", "[", "#")
        or head.startswith(("_:", "PREFIX", "BASE"))
    )


def _load(source: str | Path | bytes, format: str | None) -> tuple[bytes, str]:
    from graph_store.rdf.export import normalise_format

    if isinstance(source, bytes):
        data, path = source, None
    elif isinstance(source, str) and _looks_like_document(source):
        data, path = source.encode("utf-8"), None
    else:
        path = Path(source)
        try:
            data = path.read_bytes()
        except OSError as exc:
            raise RDFFormatError(f"cannot read RDF file {str(path)!r}: {exc}") from exc
    if format is not None:
        return data, normalise_format(format)
    if path is not None:
        try:
            return data, _SUFFIX_FORMATS[path.suffix.lower()]
        except KeyError:
            known = ", ".join(sorted(_SUFFIX_FORMATS))
            raise RDFFormatError(
                f"cannot tell the RDF format of {str(path)!r} from its suffix"
                f" (known: {known}); pass format="
            ) from None
    first = data.lstrip()[:1]
    return data, "jsonld" if first in (b"{", b"[") else "turtle"


def scenes_from_triples(triples: Iterable[Triple]) -> list[SceneGraph]:
    """Scene graphs from parsed triples (see :func:`read_scenes`)."""
    return _Reader(TripleIndex(triples)).read()


@contextmanager
def _as_rdf_error(where: str) -> Iterator[None]:
    """Turn an InvalidSceneError raised by a type constructor into an RDFFormatError."""
    try:
        yield
    except InvalidSceneError as exc:
        raise RDFFormatError(f"{where}: {exc}") from exc


_COORDS = ("centroidX", "centroidY", "centroidZ", "minX", "minY", "minZ", "maxX", "maxY", "maxZ")
_RelKey = tuple[str, int, RelationType, int]


class _Reader:
    def __init__(self, index: TripleIndex) -> None:
        self.ix = index
        self.scenes: dict[str, SceneMeta] = {}  # scene node -> meta
        self.entities: dict[str, tuple[str, Entity]] = {}  # entity node -> (scene node, entity)
        self.relations: dict[_RelKey, dict[str, float] | None] = {}
        self.views: dict[str, tuple[str, View]] = {}  # view node -> (scene node, view)
        self.masks: dict[str, list[MaskRecord]] = {}  # scene node -> masks

    def read(self) -> list[SceneGraph]:
        for node in self.ix.of_type(_C["Scene"]):
            self._read_scene(node)
        if len({m.scene_id for m in self.scenes.values()}) != len(self.scenes):
            ids = sorted(m.scene_id for m in self.scenes.values())
            dup = next(a for a, b in itertools.pairwise(ids) if a == b)
            raise RDFFormatError(f"scene id {dup!r} is used by two scene nodes")
        for node in self.ix.of_type(_C["Entity"]):
            self._read_entity(node)
        self._read_relations()
        for node in self.ix.of_type(_C["RelationAssertion"]):
            self._read_assertion(node)
        for node in self.ix.of_type(_C["View"]):
            self._read_view(node)
        for node in self.ix.of_type(_C["Mask"]):
            self._read_mask(node)
        return self._assemble()

    def _where(self, scene_node: str, what: str, node: str) -> str:
        return f"scene {self.scenes[scene_node].scene_id!r}, {what} {show(node)}"

    def _read_scene(self, node: str) -> None:
        ix, c = self.ix, _C
        sid = ix.string(node, c["sceneId"], f"scene {show(node)}")
        where = f"scene {sid!r} ({show(node)})"
        prov: dict[str, str] = {}
        for p_node in ix.nodes(node, c["provenance"], where):
            p_where = f"{where}, provenance {show(p_node)}"
            key = ix.string(p_node, c["key"], p_where)
            if key in prov:
                raise RDFFormatError(f"{where}: provenance {key!r} is given twice")
            prov[key] = ix.string(p_node, c["value"], p_where)
        defaults = SceneMeta(sid)
        with _as_rdf_error(where):
            self.scenes[node] = SceneMeta(
                sid,
                name=ix.opt_string(node, c["name"], where),
                units=ix.opt_string(node, c["units"], where) or defaults.units,
                up_axis=ix.opt_string(node, c["upAxis"], where) or defaults.up_axis,
                source=ix.opt_string(node, c["source"], where) or defaults.source,
                config_hash=ix.opt_string(node, c["configHash"], where),
                provenance=tuple(prov.items()),
            )

    def _scene_of(self, node: str, where: str) -> str:
        scene = self.ix.node(node, _C["inScene"], where)
        if scene not in self.scenes:
            raise RDFFormatError(f"{where}: csg:inScene {show(scene)} is not a csg:Scene")
        return scene

    def _read_entity(self, node: str) -> None:
        ix, c = self.ix, _C
        scene = self._scene_of(node, f"entity {show(node)}")
        where = self._where(scene, "entity", node)
        d = [ix.double(node, c[n], where) for n in _COORDS]
        attrs = [self._attribute(a, where) for a in ix.nodes(node, c["hasAttribute"], where)]
        with _as_rdf_error(where):
            entity = Entity(
                id=ix.integer(node, c["localId"], where),
                category=ix.string(node, c["category"], where),
                centroid=(d[0], d[1], d[2]),
                bbox_min=(d[3], d[4], d[5]),
                bbox_max=(d[6], d[7], d[8]),
                external_id=ix.opt_string(node, c["externalId"], where),
                caption=ix.opt_string(node, c["caption"], where),
                point_count=ix.opt_integer(node, c["pointCount"], where) or 0,
                confidence=ix.opt_double(node, c["confidence"], where),
                attributes=tuple(attrs),
            )
        self.entities[node] = (scene, entity)

    def _attribute(self, node: str, where: str) -> Attribute:
        ix, c = self.ix, _C
        where = f"{where}, attribute {show(node)}"
        source = ix.opt_string(node, c["attributeSource"], where)
        try:
            src = AttributeSource.INPUT if source is None else AttributeSource(source)
        except ValueError:
            known = ", ".join(s.value for s in AttributeSource)
            raise RDFFormatError(
                f"{where}: unknown attribute source {source!r}; expected one of: {known}"
            ) from None
        with _as_rdf_error(where):
            return Attribute(
                ix.string(node, c["key"], where), ix.string(node, c["value"], where), src
            )

    def _entity_ref(self, where: str, prop: str, target: str, scene: str | None) -> Entity:
        found = self.entities.get(target)
        if found is None:
            raise RDFFormatError(f"{where}: {short(prop)} {show(target)} is not a csg:Entity")
        if scene is not None and found[0] != scene:
            raise RDFFormatError(
                f"{where}: {short(prop)} {show(target)} is an entity of another scene"
            )
        return found[1]

    def _read_relations(self) -> None:
        for node, by_pred in self.ix.props.items():
            for pred in by_pred.keys() & _RELATIONS.keys():
                rel = _RELATIONS[pred]
                found = self.entities.get(node)
                if found is None:
                    raise RDFFormatError(f"{short(pred)} from {show(node)}, not a csg:Entity")
                scene, src = found
                where = self._where(scene, "entity", node)
                if not rel.is_stored:
                    raise RDFFormatError(
                        f"{where}: {short(pred)} is view-dependent and is never stored"
                    )
                for target in self.ix.nodes(node, pred, where):
                    dst = self._entity_ref(where, pred, target, scene)
                    self.relations[(scene, src.id, rel, dst.id)] = None

    def _read_assertion(self, node: str) -> None:
        ix, c = self.ix, _C
        where = f"relation assertion {show(node)}"
        subj = ix.node(node, c["subject"], where)
        src = self._entity_ref(where, c["subject"], subj, None)
        scene = self.entities[subj][0]
        where = self._where(scene, "relation assertion", node)
        pred = ix.node(node, c["predicate"], where)
        rel = _RELATIONS.get(pred)
        if rel is None:
            raise RDFFormatError(f"{where}: csg:predicate {show(pred)} is not a relation")
        obj = ix.node(node, c["object"], where)
        dst = self._entity_ref(where, c["object"], obj, scene)
        key = (scene, src.id, rel, dst.id)
        if key not in self.relations:
            raise RDFFormatError(
                f"{where}: no matching triple {show(subj)} {short(pred)} {show(obj)}"
            )
        if self.relations[key] is not None:
            raise RDFFormatError(f"{where}: the relation is asserted twice")
        evidence: dict[str, float] = {}
        for ev in ix.nodes(node, c["hasEvidence"], where):
            ev_where = f"{where}, evidence {show(ev)}"
            name = ix.string(ev, c["name"], ev_where)
            if name in evidence:
                raise RDFFormatError(f"{where}: evidence {name!r} is given twice")
            evidence[name] = ix.double(ev, c["value"], ev_where)
        self.relations[key] = evidence

    def _read_view(self, node: str) -> None:
        ix, c = self.ix, _C
        scene = self._scene_of(node, f"view {show(node)}")
        where = self._where(scene, "view", node)
        with _as_rdf_error(where):
            view = View(
                ix.integer(node, c["localId"], where),
                ix.string(node, c["name"], where),
                ix.integer(node, c["width"], where),
                ix.integer(node, c["height"], where),
            )
        self.views[node] = (scene, view)

    def _read_mask(self, node: str) -> None:
        ix, c = self.ix, _C
        where = f"mask {show(node)}"
        view_node = ix.node(node, c["inView"], where)
        if view_node not in self.views:
            raise RDFFormatError(f"{where}: csg:inView {show(view_node)} is not a csg:View")
        scene, view = self.views[view_node]
        where = self._where(scene, "mask", node)
        target = ix.opt_node(node, c["assignedTo"], where)
        entity = None if target is None else self._entity_ref(where, c["assignedTo"], target, scene)
        with _as_rdf_error(where):
            mask = MaskRecord(
                view.id,
                ix.integer(node, c["maskIndex"], where),
                None if entity is None else entity.id,
                ix.opt_string(node, c["label"], where),
                ix.opt_double(node, c["score"], where),
            )
        self.masks.setdefault(scene, []).append(mask)

    def _assemble(self) -> list[SceneGraph]:
        members: dict[str, tuple[list[Entity], list[Relation], list[View]]] = {
            s: ([], [], []) for s in self.scenes
        }
        for scene, entity in self.entities.values():
            members[scene][0].append(entity)
        for scene, view in self.views.values():
            members[scene][2].append(view)
        for (scene, src, rel, dst), evidence in self.relations.items():
            with _as_rdf_error(f"scene {self.scenes[scene].scene_id!r}"):
                evidence_pairs = tuple(sorted((evidence or {}).items()))
                members[scene][1].append(Relation(src, dst, rel, evidence_pairs))
        out = []
        for node, meta in self.scenes.items():
            entities, relations, views = members[node]
            with _as_rdf_error(f"scene {meta.scene_id!r}"):
                graph = SceneGraph(
                    meta,
                    tuple(entities),
                    tuple(relations),
                    tuple(views),
                    tuple(self.masks.get(node, [])),
                )
            out.append(graph)
        return sorted(out, key=lambda g: g.scene_id)
