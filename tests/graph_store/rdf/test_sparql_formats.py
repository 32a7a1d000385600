"""W3C documents of SPARQL results (graph_store.rdf.results), read back by rdflib's result
and RDF parsers, on both engines."""

from __future__ import annotations

import io
import json

import pytest
import rdflib
from rdflib import BNode, Literal, URIRef
from rdflib.compare import isomorphic
from rdflib.query import Result

from graph_store import SparqlFormatError
from graph_store.rdf import CSG, RdfView, entity_iri
from tests.graph_store.rdf.test_sparql_query import TRICKY, small_scene

BACKENDS = ("oxigraph", "rdflib")
XSD = rdflib.Namespace("http://www.w3.org/2001/XMLSchema#")
NOT_AN_IRI = "http://example.org/not-an-iri"

# One row of every kind of term: IRI, plain, typed and language-tagged literals, a string
# that spells an IRI, a blank node, and an unbound variable.
SELECT = """
SELECT ?e ?cat ?conf ?id ?label ?caption ?blank ?none WHERE {
    ?e csg:localId ?id ; csg:category ?cat .
    OPTIONAL { ?e csg:confidence ?conf }
    OPTIONAL { ?e csg:caption ?caption }
    OPTIONAL { ?e csg:nothing ?none }
    BIND(STRLANG(?cat, "en") AS ?label)
    BIND(BNODE() AS ?blank)
} ORDER BY ?id
"""


@pytest.fixture(scope="module", params=BACKENDS)
def view(request: pytest.FixtureRequest) -> RdfView:
    return RdfView.from_graphs(small_scene(), backend=request.param)


def _expected_rows() -> list[dict[str, object]]:
    rows = []
    for i, cat in enumerate(["floor", "table", "cup", TRICKY]):
        row: dict[str, object] = {
            "e": URIRef(entity_iri("kitchen", i)),
            "cat": Literal(cat),
            "id": Literal(str(i), datatype=XSD.integer),
            "label": Literal(cat, lang="en"),
        }
        if i == 1:
            row["conf"] = Literal("0.75", datatype=XSD.double)
        if i == 3:
            row["caption"] = Literal(NOT_AN_IRI)
        rows.append(row)
    return rows


def _parsed_rows(result: Result) -> list[dict[str, object]]:
    out = []
    for row in result.bindings:
        plain = {str(k): v for k, v in row.items() if v is not None}
        assert isinstance(plain.pop("blank"), BNode)
        if "conf" in plain:  # compare the double by value (lexical forms may differ)
            conf = plain["conf"]
            assert isinstance(conf, Literal) and conf.datatype == XSD.double
            plain["conf"] = Literal(repr(float(conf)), datatype=XSD.double)
        out.append(plain)
    return out


@pytest.mark.parametrize("fmt", ["json", "xml", "tsv"])
def test_select_documents_keep_every_term_typed(view: RdfView, fmt: str) -> None:
    result = view.query(SELECT)
    text = result.serialize(fmt)  # type: ignore[arg-type]
    parsed = Result.parse(io.BytesIO(text.encode("utf-8")), format=fmt)
    assert [str(v) for v in parsed.vars or []] == list(result.columns)
    assert _parsed_rows(parsed) == _expected_rows()


def test_json_tells_an_iri_from_a_string_that_spells_one(view: RdfView) -> None:
    doc = json.loads(view.query(SELECT).serialize("json"))
    assert doc["head"]["vars"] == ["e", "cat", "conf", "id", "label", "caption", "blank", "none"]
    first, second, _, last = doc["results"]["bindings"]
    assert first["e"] == {"type": "uri", "value": entity_iri("kitchen", 0)}
    assert last["caption"] == {"type": "literal", "value": NOT_AN_IRI}
    assert first["id"] == {"type": "literal", "value": "0", "datatype": str(XSD.integer)}
    assert first["label"] == {"type": "literal", "value": "floor", "xml:lang": "en"}
    assert first["blank"]["type"] == "bnode" and "none" not in first
    assert "conf" not in first and second["conf"]["datatype"] == str(XSD.double)


def test_csv_has_lexical_forms_and_crlf_lines(view: RdfView) -> None:
    text = view.query("SELECT ?id ?cat WHERE { ?e csg:localId ?id ; csg:category ?cat }"
                      " ORDER BY ?id").serialize("csv")  # fmt: skip
    assert text.startswith("id,cat\r\n0,floor\r\n1,table\r\n")
    parsed = Result.parse(io.BytesIO(text.encode("utf-8")), format="csv")
    assert [str(r[1]) for r in parsed] == ["floor", "table", "cup", TRICKY]  # type: ignore[index]


def test_ask_is_json_or_xml_only(view: RdfView) -> None:
    for query, answer in (("ASK { ?a csg:above ?b }", True), ("ASK { ?a csg:inside ?b }", False)):
        result = view.query(query)
        assert json.loads(result.serialize()) == {"head": {}, "boolean": answer}
        parsed = Result.parse(io.BytesIO(result.serialize("xml").encode()), format="xml")
        assert parsed.askAnswer is answer
        with pytest.raises(SparqlFormatError, match="an ASK result cannot be written as 'csv'"):
            result.serialize("csv")


CONSTRUCT = """
CONSTRUCT { ?e csg:category ?cat ; csg:label ?label ; csg:near ?b . ?b csg:localId ?id }
WHERE { ?e csg:category ?cat ; csg:localId ?id . BIND(STRLANG(?cat, "en") AS ?label)
        BIND(BNODE() AS ?b) }
"""


@pytest.mark.parametrize(
    ("fmt", "parser"),
    [("turtle", "turtle"), ("ntriples", "nt"), ("jsonld", "json-ld"), ("rdfxml", "xml")],
)
def test_graph_results_are_rdf_documents(view: RdfView, fmt: str, parser: str) -> None:
    result = view.query(CONSTRUCT)
    assert result.kind == "graph" and len(result.terms) == 16
    expected = rdflib.Graph()
    blanks: dict[int, BNode] = {}
    for i, cat in enumerate(["floor", "table", "cup", TRICKY]):
        e, b = URIRef(entity_iri("kitchen", i)), blanks.setdefault(i, BNode())
        expected.add((e, CSG.category, Literal(cat)))
        expected.add((e, CSG.label, Literal(cat, lang="en")))
        expected.add((e, CSG.near, b))
        expected.add((b, CSG.localId, Literal(str(i), datatype=XSD.integer)))
    graph = rdflib.Graph().parse(data=result.serialize(fmt), format=parser)  # type: ignore[arg-type]
    assert isomorphic(graph, expected)
    with pytest.raises(SparqlFormatError, match="use one of: turtle, ntriples, jsonld, rdfxml"):
        result.serialize("json")


def test_xml_refuses_characters_it_cannot_hold(view: RdfView) -> None:
    result = view.query('SELECT ?x WHERE { BIND("bell \\u0007" AS ?x) }')
    assert json.loads(result.serialize("json"))["results"]["bindings"][0]["x"]["value"] == (
        "bell \x07"
    )
    with pytest.raises(SparqlFormatError, match="U\\+0007"):
        result.serialize("xml")


def test_a_truncated_result_writes_its_first_rows(view: RdfView) -> None:
    result = view.query("SELECT ?e WHERE { ?e csg:localId ?id } ORDER BY ?id", limit=2)
    assert result.truncated
    assert len(json.loads(result.serialize())["results"]["bindings"]) == 2
    assert result.serialize("tsv").count("\n") == 3
