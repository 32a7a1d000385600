"""Export scene graphs as RDF: Turtle, N-Triples (streaming writers) and JSON-LD.

The mapping (vocabulary in ``csg.ttl``, IRIs in :mod:`graph_store.rdf.iris`):

* scene ``a csg:Scene, bot:Space`` with ``csg:sceneId``, ``csg:name``, ``csg:units``,
  ``csg:upAxis``, ``csg:source``, ``csg:configHash`` and ``csg:provenance`` entries
  (``csg:key``/``csg:value``); ``created_at`` is not exported;
* entity ``a csg:Entity, bot:Element`` with ``csg:inScene`` (and ``scene
  bot:containsElement entity``), ``csg:localId``, ``csg:externalId``, ``csg:category`` (also
  ``rdfs:label``), ``csg:caption``, ``csg:centroidX/Y/Z``, ``csg:minX..maxZ``,
  ``csg:pointCount``, ``csg:confidence``, a GeoSPARQL point (``geo:hasGeometry`` /
  ``geo:asWKT "POINT Z(x y z)"``) and ``csg:hasAttribute`` nodes (``csg:key``, ``csg:value``,
  ``csg:attributeSource``);
* every stored relation as a direct triple ``src csg:<type> dst`` and, with ``evidence=True``,
  a ``csg:RelationAssertion`` node (``csg:subject``, ``csg:predicate``, ``csg:object``) whose
  ``csg:hasEvidence`` nodes carry ``csg:name`` / ``csg:value`` (``xsd:double``);
* views (``csg:View``) and masks (``csg:Mask``, ``csg:inView``, ``csg:maskIndex``,
  ``csg:assignedTo``, ``csg:label``, ``csg:score``).

Doubles are written as ``repr(float)`` with datatype ``xsd:double`` and read back exactly.
Turtle and N-Triples are built as strings directly (no rdflib), one subject block at a time;
JSON-LD is grouped by subject from the N-Triples, with every literal as a typed string.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Literal, TextIO

from graph_store.errors import InvalidSceneError, RDFFormatError
from graph_store.rdf._terms import NTRIPLES, TURTLE, Tokens, quoted, turtle_header
from graph_store.rdf.iris import quote_segment as _q
from graph_store.rdf.iris import scene_iri
from graph_store.types import Entity, SceneGraph

RdfFormatName = Literal["turtle", "ntriples", "jsonld"]

_FORMAT_ALIASES = {
    "turtle": "turtle",
    "ttl": "turtle",
    "ntriples": "ntriples",
    "nt": "ntriples",
    "n-triples": "ntriples",
    "jsonld": "jsonld",
    "json-ld": "jsonld",
}


def normalise_format(format: str) -> str:
    """``"turtle"``, ``"ntriples"`` or ``"jsonld"`` for a format name or common alias."""
    try:
        return _FORMAT_ALIASES[format.lower()]
    except (KeyError, AttributeError):
        known = ", ".join(sorted(set(_FORMAT_ALIASES.values())))
        raise RDFFormatError(f"unknown RDF format {format!r}; expected one of: {known}") from None


def as_scene_list(graphs: SceneGraph | Iterable[SceneGraph]) -> list[SceneGraph]:
    """One graph or several as a list; refuses non-graphs and repeated scene ids."""
    items = [graphs] if isinstance(graphs, SceneGraph) else list(graphs)
    seen: set[str] = set()
    for g in items:
        if not isinstance(g, SceneGraph):
            raise InvalidSceneError(f"expected a SceneGraph, got {type(g).__name__}")
        if g.scene_id in seen:
            raise InvalidSceneError(f"scene {g.scene_id!r} is given twice")
        seen.add(g.scene_id)
    return items


def serialize_scenes(
    graphs: SceneGraph | Iterable[SceneGraph],
    format: RdfFormatName | str = "turtle",
    *,
    evidence: bool = True,
) -> str:
    """The RDF view of one or more scene graphs as a document in ``format``.

    ``evidence=False`` leaves out the relation assertion nodes (only the direct relation
    triples remain; reading the document back gives relations without evidence).
    """
    fmt = normalise_format(format)
    items = as_scene_list(graphs)
    if fmt == "jsonld":
        return _jsonld(items, evidence)
    return "".join(iter_chunks(items, turtle=fmt == "turtle", evidence=evidence))


def _jsonld(items: list[SceneGraph], evidence: bool) -> str:
    """JSON-LD, built from the N-Triples text so that both say exactly the same."""
    from graph_store.rdf._jsonld import jsonld_from_triples
    from graph_store.rdf._parse import parse_triples

    ntriples = "".join(iter_chunks(items, turtle=False, evidence=evidence))
    return jsonld_from_triples(parse_triples(ntriples.encode("utf-8"), "ntriples"))


def write_scenes(
    graphs: SceneGraph | Iterable[SceneGraph],
    path_or_textio: str | os.PathLike[str] | TextIO,
    format: RdfFormatName | str = "turtle",
    *,
    evidence: bool = True,
) -> None:
    """Write :func:`serialize_scenes` output to a text stream or a file.

    A file is written next to its final path and renamed into place when complete, so a
    failure never leaves a half-written document behind.
    """
    fmt = normalise_format(format)
    items = as_scene_list(graphs)
    if not isinstance(path_or_textio, str | os.PathLike):
        _write_to(items, path_or_textio, fmt, evidence)
        return
    path = Path(path_or_textio)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        with tmp.open("w", encoding="utf-8", newline="") as out:
            _write_to(items, out, fmt, evidence)
        os.replace(tmp, path)
    except OSError as exc:  # name the file asked for, not the temporary
        if exc.filename is not None and Path(exc.filename) == tmp:
            raise type(exc)(exc.errno, exc.strerror, str(path)) from None
        raise
    finally:
        tmp.unlink(missing_ok=True)


def _write_to(items: list[SceneGraph], out: TextIO, fmt: str, evidence: bool) -> None:
    if fmt == "jsonld":
        out.write(_jsonld(items, evidence))
        return
    batch: list[str] = []
    for chunk in iter_chunks(items, turtle=fmt == "turtle", evidence=evidence):
        batch.append(chunk)
        if len(batch) >= 4096:
            out.write("".join(batch))
            batch.clear()
    out.write("".join(batch))


def iter_chunks(items: Iterable[SceneGraph], *, turtle: bool, evidence: bool) -> Iterator[str]:
    """Turtle (with its prefix header) or N-Triples text, a few subject blocks at a time."""
    tok = TURTLE if turtle else NTRIPLES
    if turtle:
        yield turtle_header()
    for graph in items:
        yield from _scene_chunks(graph, tok, evidence)


def _block(subject: str, pairs: list[str], turtle: bool) -> str:
    """All triples of one subject; ``pairs`` are ``"predicate object"`` strings."""
    if turtle:
        return subject + " " + " ;\n    ".join(pairs) + " .\n"
    return subject + " " + (" .\n" + subject + " ").join(pairs) + " .\n"


def _dbl(value: float, tok: Tokens) -> str:
    return '"' + repr(value) + tok.double_suffix


def _scene_chunks(graph: SceneGraph, tok: Tokens, evidence: bool) -> Iterator[str]:
    meta, p, tt = graph.meta, tok.p, tok.turtle
    base = scene_iri(meta.scene_id)
    s = "<" + base + ">"
    pairs = [*tok.scene_types, p["sceneId"] + " " + quoted(meta.scene_id)]
    if meta.name is not None:
        pairs.append(p["name"] + " " + quoted(meta.name))
    pairs.append(p["units"] + " " + quoted(meta.units))
    pairs.append(p["upAxis"] + " " + quoted(meta.up_axis))
    pairs.append(p["source"] + " " + quoted(meta.source))
    if meta.config_hash is not None:
        pairs.append(p["configHash"] + " " + quoted(meta.config_hash))
    prov_blocks = []
    for key, value in meta.provenance:
        node = f"<{base}/provenance/{_q(key)}>"
        pairs.append(p["provenance"] + " " + node)
        prov_blocks.append(
            _block(node, [p["key"] + " " + quoted(key), p["value"] + " " + quoted(value)], tt)
        )
    contains = p["containsElement"] + " <" + base + "/entity/"
    pairs.extend(contains + str(e.id) + ">" for e in graph.entities)
    yield _block(s, pairs, tt)
    yield "".join(prov_blocks)
    yield from _entity_chunks(graph, base, s, tok)
    if evidence:
        yield from _assertion_chunks(graph, base, tok)
    yield from _view_chunks(graph, base, s, tok)


def _entity_chunks(graph: SceneGraph, base: str, s: str, tok: Tokens) -> Iterator[str]:
    rels = graph.relations
    n_rels, r_i = len(rels), 0
    rel_tok = tok.rel
    in_scene = tok.p["inScene"] + " " + s
    ent_prefix = "<" + base + "/entity/"
    out: list[str] = []
    for e in graph.entities:
        eid = str(e.id)
        subject = ent_prefix + eid + ">"
        pairs = _entity_pairs(e, subject, in_scene, tok)
        while r_i < n_rels and rels[r_i].src == e.id:
            r = rels[r_i]
            pairs.append(rel_tok[r.type.value] + " " + ent_prefix + str(r.dst) + ">")
            r_i += 1
        out.append(_block(subject, pairs, tok.turtle))
        out.append(_entity_nodes(e, subject, tok))
        if len(out) >= 512:
            yield "".join(out)
            out.clear()
    yield "".join(out)


def _entity_pairs(e: Entity, subject: str, in_scene: str, tok: Tokens) -> list[str]:
    p, ds = tok.p, tok.double_suffix
    cx, cy, cz = e.centroid
    lo, hi = e.bbox_min, e.bbox_max
    cat = quoted(e.category)
    pairs = [
        *tok.entity_types,
        in_scene,
        p["localId"] + " " + tok.integer(e.id),
        p["category"] + " " + cat,
        p["rdfsLabel"] + " " + cat,
        f'{p["centroidX"]} "{cx!r}{ds}',
        f'{p["centroidY"]} "{cy!r}{ds}',
        f'{p["centroidZ"]} "{cz!r}{ds}',
        f'{p["minX"]} "{lo[0]!r}{ds}',
        f'{p["minY"]} "{lo[1]!r}{ds}',
        f'{p["minZ"]} "{lo[2]!r}{ds}',
        f'{p["maxX"]} "{hi[0]!r}{ds}',
        f'{p["maxY"]} "{hi[1]!r}{ds}',
        f'{p["maxZ"]} "{hi[2]!r}{ds}',
        p["pointCount"] + " " + tok.integer(e.point_count),
        p["hasGeometry"] + " " + subject[:-1] + "/geometry>",
    ]
    if e.external_id is not None:
        pairs.append(p["externalId"] + " " + quoted(e.external_id))
    if e.caption is not None:
        pairs.append(p["caption"] + " " + quoted(e.caption))
    if e.confidence is not None:
        pairs.append(p["confidence"] + " " + _dbl(e.confidence, tok))
    stem = subject[:-1] + "/attribute/"
    for a in e.attributes:
        pairs.append(f"{p['hasAttribute']} {stem}{_q(a.key)}/{_q(a.value)}>")
    return pairs


def _entity_nodes(e: Entity, subject: str, tok: Tokens) -> str:
    """The geometry node and the attribute nodes of one entity."""
    p, tt = tok.p, tok.turtle
    cx, cy, cz = e.centroid
    wkt = f'"POINT Z({cx!r} {cy!r} {cz!r}){tok.wkt_suffix}'
    parts = [_block(subject[:-1] + "/geometry>", [tok.geometry_type, p["asWKT"] + " " + wkt], tt)]
    stem = subject[:-1] + "/attribute/"
    for a in e.attributes:
        node = f"{stem}{_q(a.key)}/{_q(a.value)}>"
        attr_pairs = [
            tok.attribute_type,
            p["key"] + " " + quoted(a.key),
            p["value"] + " " + quoted(a.value),
            p["attributeSource"] + " " + quoted(a.source.value),
        ]
        parts.append(_block(node, attr_pairs, tt))
    return "".join(parts)


def _assertion_chunks(graph: SceneGraph, base: str, tok: Tokens) -> Iterator[str]:
    p, tt, rel_tok = tok.p, tok.turtle, tok.rel
    ent_prefix = "<" + base + "/entity/"
    rel_prefix = "<" + base + "/relation/"
    head = (tok.assertion_type, p["subject"], p["predicate"], p["object"], p["hasEvidence"])
    a_type, p_subj, p_pred, p_obj, p_ev = head
    name_p, value_p, ds = p["name"] + " ", p["value"] + ' "', tok.double_suffix
    out: list[str] = []
    for r in graph.relations:
        src, dst, rt = str(r.src), str(r.dst), r.type.value
        node = rel_prefix + src + "/" + rt + "/" + dst
        pairs = [
            a_type,
            p_subj + " " + ent_prefix + src + ">",
            p_pred + " " + rel_tok[rt],
            p_obj + " " + ent_prefix + dst + ">",
        ]
        for name, value in r.evidence:
            ev = node + "/evidence/" + _q(name) + ">"
            pairs.append(p_ev + " " + ev)
            out.append(_block(ev, [name_p + quoted(name), value_p + repr(value) + ds], tt))
        out.append(_block(node + ">", pairs, tt))
        if len(out) >= 1024:
            yield "".join(out)
            out.clear()
    yield "".join(out)


def _view_chunks(graph: SceneGraph, base: str, s: str, tok: Tokens) -> Iterator[str]:
    p, tt = tok.p, tok.turtle
    out: list[str] = []
    for v in graph.views:
        pairs = [
            tok.view_type,
            p["inScene"] + " " + s,
            p["localId"] + " " + tok.integer(v.id),
            p["name"] + " " + quoted(v.name),
            p["width"] + " " + tok.integer(v.width),
            p["height"] + " " + tok.integer(v.height),
        ]
        out.append(_block(f"<{base}/view/{v.id}>", pairs, tt))
    for m in graph.masks:
        pairs = [
            tok.mask_type,
            f"{p['inView']} <{base}/view/{m.view}>",
            p["maskIndex"] + " " + tok.integer(m.index),
        ]
        if m.entity is not None:
            pairs.append(f"{p['assignedTo']} <{base}/entity/{m.entity}>")
        if m.label is not None:
            pairs.append(p["label"] + " " + quoted(m.label))
        if m.score is not None:
            pairs.append(p["score"] + " " + _dbl(m.score, tok))
        out.append(_block(f"<{base}/view/{m.view}/mask/{m.index}>", pairs, tt))
    yield "".join(out)
