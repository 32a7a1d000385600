"""RDF and SPARQL for scene graphs.

* The vocabulary: ``csg.ttl`` (:data:`VOCAB_PATH`) and its Python mirror :data:`CSG`,
  aligned with the Building Topology Ontology (:data:`BOT`) and GeoSPARQL (:data:`GEO`).
* Export: :func:`serialize_scenes` / :func:`write_scenes` (Turtle, N-Triples, JSON-LD) and
  :func:`to_rdflib_graph`; import: :func:`read_scenes`.
* Read-only SPARQL: :class:`RdfView` and its :class:`SparqlResult`, whose ``serialize``
  writes the W3C result formats (:mod:`graph_store.rdf.results`); :func:`query_kind`.
"""

from graph_store.rdf._rdflib_graph import to_rdflib_graph
from graph_store.rdf.export import serialize_scenes, write_scenes
from graph_store.rdf.importer import read_scenes
from graph_store.rdf.iris import entity_iri, scene_iri
from graph_store.rdf.namespace import BOT, CSG, GEO, VOCAB_PATH
from graph_store.rdf.sparql import RdfView, SparqlResult, query_kind

__all__ = [
    "BOT",
    "CSG",
    "GEO",
    "VOCAB_PATH",
    "RdfView",
    "SparqlResult",
    "entity_iri",
    "query_kind",
    "read_scenes",
    "scene_iri",
    "serialize_scenes",
    "to_rdflib_graph",
    "write_scenes",
]
