"""The CausalSplat RDF vocabulary (``csg:``) and the standard namespaces it aligns with.

:data:`CSG` mirrors the Turtle file shipped at :data:`VOCAB_PATH` term for term; with
``_fail = True`` a misspelt term raises ``AttributeError`` instead of minting a new IRI.
A test keeps the Turtle file, :data:`CSG` and :class:`~graph_store.types.RelationType` in step.
"""

from __future__ import annotations

from pathlib import Path
from types import MappingProxyType

from rdflib import Namespace, URIRef
from rdflib.namespace import OWL, RDF, RDFS, XSD, DefinedNamespace

#: The Turtle file of the vocabulary, shipped as package data.
VOCAB_PATH: Path = Path(__file__).with_name("csg.ttl")

#: The IRI of the vocabulary as an ontology (``owl:Ontology``).
ONTOLOGY_IRI = "https://w3id.org/causalsplat/ns"

#: Building Topology Ontology.
BOT = Namespace("https://w3id.org/bot#")

#: OGC GeoSPARQL.
GEO = Namespace("http://www.opengis.net/ont/geosparql#")


class CSG(DefinedNamespace):
    """The ``csg:`` vocabulary: scenes, entities, attributes, relations, views, masks."""

    _NS = Namespace(ONTOLOGY_IRI + "#")
    _fail = True

    # classes
    Scene: URIRef
    Entity: URIRef
    Attribute: URIRef
    RelationAssertion: URIRef
    Evidence: URIRef
    ProvenanceEntry: URIRef
    View: URIRef
    Mask: URIRef

    # scene
    sceneId: URIRef
    name: URIRef
    units: URIRef
    upAxis: URIRef
    source: URIRef
    configHash: URIRef
    provenance: URIRef
    key: URIRef
    value: URIRef
    inScene: URIRef
    localId: URIRef

    # entity
    externalId: URIRef
    category: URIRef
    caption: URIRef
    centroidX: URIRef
    centroidY: URIRef
    centroidZ: URIRef
    minX: URIRef
    minY: URIRef
    minZ: URIRef
    maxX: URIRef
    maxY: URIRef
    maxZ: URIRef
    pointCount: URIRef
    confidence: URIRef
    hasAttribute: URIRef
    attributeSource: URIRef

    # relation assertions
    subject: URIRef
    predicate: URIRef
    object: URIRef
    hasEvidence: URIRef

    # spatial relations (local names are the RelationType values)
    spatialRelation: URIRef
    above: URIRef
    below: URIRef
    supported_by: URIRef
    supports: URIRef
    inside: URIRef
    contains: URIRef
    near: URIRef
    next_to: URIRef
    left_of: URIRef
    right_of: URIRef
    in_front_of: URIRef
    behind: URIRef

    # views and masks
    width: URIRef
    height: URIRef
    inView: URIRef
    maskIndex: URIRef
    assignedTo: URIRef
    label: URIRef
    score: URIRef


#: Prefixes used by the Turtle writer and predeclared for SPARQL queries.
PREFIXES: MappingProxyType[str, str] = MappingProxyType(
    {
        "csg": str(CSG._NS),
        "bot": str(BOT),
        "geo": str(GEO),
        "rdf": str(RDF),
        "rdfs": str(RDFS),
        "xsd": str(XSD),
        "owl": str(OWL),
    }
)


def csg_local_names() -> frozenset[str]:
    """The local names of every term of :data:`CSG` (the vocabulary in ``csg.ttl``)."""
    return frozenset(name for name in CSG.__annotations__ if not name.startswith("_"))
