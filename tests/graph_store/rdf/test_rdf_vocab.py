"""The vocabulary file, its Python mirror and the RelationType enum stay in step."""

from __future__ import annotations

import importlib.resources

import pytest
from rdflib import OWL, RDF, RDFS, Graph, URIRef

from graph_store import RelationType
from graph_store.rdf import BOT, CSG, GEO, VOCAB_PATH
from graph_store.rdf.namespace import ONTOLOGY_IRI, PREFIXES, csg_local_names

NS = str(CSG._NS)


@pytest.fixture(scope="module")
def vocab() -> Graph:
    return Graph().parse(VOCAB_PATH, format="turtle")


def _terms(vocab: Graph) -> set[str]:
    return {
        str(s)[len(NS) :]
        for s in vocab.subjects()
        if isinstance(s, URIRef) and str(s).startswith(NS)
    }


def test_vocabulary_ships_with_the_package() -> None:
    packaged = importlib.resources.files("graph_store.rdf").joinpath("csg.ttl")
    assert packaged.is_file()
    assert VOCAB_PATH.read_bytes() == packaged.read_bytes()


def test_vocabulary_is_an_ontology(vocab: Graph) -> None:
    onto = URIRef(ONTOLOGY_IRI)
    assert (onto, RDF.type, OWL.Ontology) in vocab
    assert vocab.value(onto, RDFS.label) is not None
    assert vocab.value(onto, RDFS.comment) is not None
    assert NS == ONTOLOGY_IRI + "#" == PREFIXES["csg"] == "https://w3id.org/causalsplat/ns#"


def test_turtle_file_and_namespace_class_name_the_same_terms(vocab: Graph) -> None:
    assert _terms(vocab) == set(csg_local_names())
    for name in csg_local_names():
        assert str(CSG[name]) == NS + name
        assert getattr(CSG, name) == URIRef(NS + name)


def test_misspelt_terms_raise() -> None:
    with pytest.raises(AttributeError):
        _ = CSG.abovee
    with pytest.raises(AttributeError):
        _ = CSG["supportedBy"]


def test_every_term_is_declared_labelled_and_commented(vocab: Graph) -> None:
    kinds = {OWL.Class, OWL.ObjectProperty, OWL.DatatypeProperty}
    for name in csg_local_names():
        term = CSG[name]
        declared = set(vocab.objects(term, RDF.type)) & kinds
        assert len(declared) == 1, f"csg:{name} is declared as {declared}"
        assert vocab.value(term, RDFS.label) is not None, f"csg:{name} has no rdfs:label"
        assert vocab.value(term, RDFS.comment) is not None, f"csg:{name} has no rdfs:comment"
        if OWL.Class not in declared:
            assert vocab.value(term, RDFS.range) is not None, f"csg:{name} has no rdfs:range"


def test_every_relation_type_is_a_spatial_relation_property(vocab: Graph) -> None:
    for rel in RelationType:
        prop = CSG[rel.value]
        assert (prop, RDF.type, OWL.ObjectProperty) in vocab
        assert (prop, RDFS.subPropertyOf, CSG.spatialRelation) in vocab
        assert (prop, RDFS.domain, CSG.Entity) in vocab
        assert (prop, RDFS.range, CSG.Entity) in vocab
    relation_terms = {
        name
        for name in csg_local_names()
        if (CSG[name], RDFS.subPropertyOf, CSG.spatialRelation) in vocab
    }
    assert relation_terms == {rel.value for rel in RelationType}


def test_inverses_and_symmetry_match_the_enum(vocab: Graph) -> None:
    for rel in RelationType:
        prop, inv = CSG[rel.value], CSG[rel.inverse.value]
        if rel.is_symmetric:
            assert (prop, RDF.type, OWL.SymmetricProperty) in vocab
            assert (prop, OWL.inverseOf, None) not in vocab
        else:
            assert (prop, OWL.inverseOf, inv) in vocab or (inv, OWL.inverseOf, prop) in vocab
            assert (prop, RDF.type, OWL.SymmetricProperty) not in vocab
    declared = {(str(a), str(b)) for a, b in vocab.subject_objects(OWL.inverseOf)}
    assert len(declared) == sum(1 for r in RelationType if not r.is_symmetric) // 2


def test_alignment_with_bot_and_geosparql(vocab: Graph) -> None:
    assert (CSG.Entity, RDFS.subClassOf, BOT.Element) in vocab
    assert (CSG.Scene, RDFS.subClassOf, BOT.Space) in vocab
    assert str(BOT) == "https://w3id.org/bot#"
    assert str(GEO) == "http://www.opengis.net/ont/geosparql#"
    assert str(GEO.asWKT) == "http://www.opengis.net/ont/geosparql#asWKT"
