"""The RDF view of scene graphs as an rdflib ``Graph``.

This builds the same triples as the streaming writers in :mod:`graph_store.rdf.export`,
independently, through rdflib's term API; the tests hold the two against each other.
"""

from __future__ import annotations

from collections.abc import Iterable

from rdflib import RDF, RDFS, XSD, Dataset, Graph, Literal, URIRef
from rdflib.store import Store

from graph_store.rdf import iris
from graph_store.rdf.namespace import BOT, CSG, GEO, PREFIXES
from graph_store.types import Entity, SceneGraph


def to_rdflib_dataset(
    graphs: SceneGraph | Iterable[SceneGraph],
    *,
    evidence: bool = True,
    store: Store | None = None,
) -> Dataset:
    """An rdflib ``Dataset`` with each scene's RDF view in a named graph (the scene's IRI)
    and their union as the default graph (``default_union``)."""
    from graph_store.rdf.export import as_scene_list

    ds = Dataset(store=store if store is not None else "default", default_union=True)
    for prefix, ns in PREFIXES.items():
        ds.bind(prefix, ns)
    for scene in as_scene_list(graphs):
        _add_scene(ds.graph(URIRef(iris.scene_iri(scene.scene_id))), scene, evidence)
    return ds


def to_rdflib_graph(
    graphs: SceneGraph | Iterable[SceneGraph],
    *,
    evidence: bool = True,
    store: Store | None = None,
) -> Graph:
    """An rdflib ``Graph`` holding the RDF view of the scene graphs.

    ``store``: an rdflib store to fill (an in-memory one by default).
    """
    from graph_store.rdf.export import as_scene_list

    g = Graph(store=store if store is not None else "default", bind_namespaces="none")
    for prefix, ns in PREFIXES.items():
        g.bind(prefix, ns)
    for scene in as_scene_list(graphs):
        _add_scene(g, scene, evidence)
    return g


def _dbl(value: float) -> Literal:
    return Literal(repr(value), datatype=XSD.double)


def _int(value: int) -> Literal:
    return Literal(str(value), datatype=XSD.integer)


def _add_scene(g: Graph, scene: SceneGraph, evidence: bool) -> None:
    meta = scene.meta
    s_iri = iris.scene_iri(meta.scene_id)
    s = URIRef(s_iri)
    add = g.add
    add((s, RDF.type, CSG.Scene))
    add((s, RDF.type, BOT.Space))
    add((s, CSG.sceneId, Literal(meta.scene_id)))
    if meta.name is not None:
        add((s, CSG.name, Literal(meta.name)))
    add((s, CSG.units, Literal(meta.units)))
    add((s, CSG.upAxis, Literal(meta.up_axis)))
    add((s, CSG.source, Literal(meta.source)))
    if meta.config_hash is not None:
        add((s, CSG.configHash, Literal(meta.config_hash)))
    for key, value in meta.provenance:
        node = URIRef(iris.provenance_iri(s_iri, key))
        add((s, CSG.provenance, node))
        add((node, CSG.key, Literal(key)))
        add((node, CSG.value, Literal(value)))
    for e in scene.entities:
        _add_entity(g, s, meta.scene_id, e)
    for r in scene.relations:
        src = URIRef(iris.entity_iri(meta.scene_id, r.src))
        dst = URIRef(iris.entity_iri(meta.scene_id, r.dst))
        add((src, CSG[r.type.value], dst))
        if not evidence:
            continue
        node_iri = iris.relation_iri(s_iri, r.src, r.type, r.dst)
        node = URIRef(node_iri)
        add((node, RDF.type, CSG.RelationAssertion))
        add((node, CSG.subject, src))
        add((node, CSG.predicate, CSG[r.type.value]))
        add((node, CSG.object, dst))
        for name, number in r.evidence:
            ev = URIRef(iris.evidence_iri(node_iri, name))
            add((node, CSG.hasEvidence, ev))
            add((ev, CSG.name, Literal(name)))
            add((ev, CSG.value, _dbl(number)))
    _add_views(g, scene, s_iri)


def _add_entity(g: Graph, s: URIRef, scene_id: str, e: Entity) -> None:
    add = g.add
    e_iri = iris.entity_iri(scene_id, e.id)
    n = URIRef(e_iri)
    add((s, BOT.containsElement, n))
    add((n, RDF.type, CSG.Entity))
    add((n, RDF.type, BOT.Element))
    add((n, CSG.inScene, s))
    add((n, CSG.localId, _int(e.id)))
    if e.external_id is not None:
        add((n, CSG.externalId, Literal(e.external_id)))
    add((n, CSG.category, Literal(e.category)))
    add((n, RDFS.label, Literal(e.category)))
    if e.caption is not None:
        add((n, CSG.caption, Literal(e.caption)))
    names = ("centroidX", "centroidY", "centroidZ", "minX", "minY", "minZ", "maxX", "maxY", "maxZ")
    values = (*e.centroid, *e.bbox_min, *e.bbox_max)
    for name, value in zip(names, values, strict=True):
        add((n, CSG[name], _dbl(value)))
    add((n, CSG.pointCount, _int(e.point_count)))
    if e.confidence is not None:
        add((n, CSG.confidence, _dbl(e.confidence)))
    geom = URIRef(iris.geometry_iri(e_iri))
    add((n, GEO.hasGeometry, geom))
    add((geom, RDF.type, GEO.Geometry))
    x, y, z = (repr(v) for v in e.centroid)
    add((geom, GEO.asWKT, Literal(f"POINT Z({x} {y} {z})", datatype=GEO.wktLiteral)))
    for a in e.attributes:
        node = URIRef(iris.attribute_iri(e_iri, a.key, a.value))
        add((n, CSG.hasAttribute, node))
        add((node, RDF.type, CSG.Attribute))
        add((node, CSG.key, Literal(a.key)))
        add((node, CSG.value, Literal(a.value)))
        add((node, CSG.attributeSource, Literal(a.source.value)))


def _add_views(g: Graph, scene: SceneGraph, s_iri: str) -> None:
    add = g.add
    s = URIRef(s_iri)
    for v in scene.views:
        node = URIRef(iris.view_iri(s_iri, v.id))
        add((node, RDF.type, CSG.View))
        add((node, CSG.inScene, s))
        add((node, CSG.localId, _int(v.id)))
        add((node, CSG.name, Literal(v.name)))
        add((node, CSG.width, _int(v.width)))
        add((node, CSG.height, _int(v.height)))
    for m in scene.masks:
        node = URIRef(iris.mask_iri(s_iri, m.view, m.index))
        add((node, RDF.type, CSG.Mask))
        add((node, CSG.inView, URIRef(iris.view_iri(s_iri, m.view))))
        add((node, CSG.maskIndex, _int(m.index)))
        if m.entity is not None:
            add((node, CSG.assignedTo, URIRef(iris.entity_iri(scene.scene_id, m.entity))))
        if m.label is not None:
            add((node, CSG.label, Literal(m.label)))
        if m.score is not None:
            add((node, CSG.score, _dbl(m.score)))
