"""``causalsplat sparql`` writes W3C documents: Query Results JSON (read by SPARQLWrapper's
JSON reader), XML, CSV and TSV (read by rdflib), and RDF for CONSTRUCT / DESCRIBE."""

from __future__ import annotations

import io
import json
from pathlib import Path

import pytest
import rdflib
from rdflib import Literal, URIRef
from rdflib.compare import isomorphic
from rdflib.query import Result
from SPARQLWrapper.SmartWrapper import Bindings, Value
from SPARQLWrapper.Wrapper import JSON, QueryResult

from tests.causalsplat.test_cli_store import assert_one_line_error, run
from tests.causalsplat.test_objects import KITCHEN

SELECT = (
    "SELECT ?e ?c ?x ?caption WHERE { ?e csg:category ?c ; csg:centroidX ?x ."
    " OPTIONAL { ?e csg:caption ?caption } } ORDER BY ?c"
)
CONSTRUCT = "CONSTRUCT { ?e rdfs:label ?c } WHERE { ?e csg:category ?c }"


@pytest.fixture(scope="module")
def db(tmp_path_factory: pytest.TempPathFactory) -> str:
    folder = tmp_path_factory.mktemp("sparql-cli")
    objects = folder / "objects.json"
    objects.write_text(json.dumps(KITCHEN))
    url = f"sqlite:///{folder / 'store.db'}"
    run("ingest-objects", str(objects), db=url)
    return url


def test_json_is_read_by_sparqlwrapper(db: str) -> None:
    out = run("sparql", SELECT, "--json", db=db).stdout
    bindings = Bindings(QueryResult((io.BytesIO(out.encode("utf-8")), JSON)))
    assert bindings.variables == ["e", "c", "x", "caption"]
    rows = bindings.bindings
    assert [row["c"].value for row in rows] == ["sink", "towel"]
    for row in rows:
        assert row["e"].type == Value.URI and row["e"].value.startswith("https://")
        assert row["c"].type == Value.Literal and row["c"].datatype is None
        assert row["x"].datatype == "http://www.w3.org/2001/XMLSchema#double"
        assert "caption" not in row  # unbound


@pytest.mark.parametrize("fmt", ["xml", "csv", "tsv"])
def test_xml_csv_and_tsv_hold_the_json_rows(db: str, fmt: str) -> None:
    reference = Result.parse(io.BytesIO(run("sparql", SELECT, "--json", db=db).stdout.encode()),
                             format="json")  # fmt: skip
    out = run("sparql", SELECT, "--format", fmt, db=db).stdout
    parsed = Result.parse(io.BytesIO(out.encode("utf-8")), format=fmt)
    assert [str(v) for v in parsed.vars or []] == ["e", "c", "x", "caption"]
    if fmt == "csv":  # lexical forms only: the IRI and the category as text, x as a number
        got = [(r[0], r[1], float(r[2]), r[3]) for r in parsed]  # type: ignore[index]
        assert got == [(URIRef(r[0]), Literal(str(r[1])), float(r[2]), None) for r in reference]  # type: ignore[index]
    else:  # the same typed terms (doubles compared by value: parsers normalise their text)
        assert _python(parsed) == _python(reference)


def _python(result: Result) -> list[tuple[object, ...]]:
    return [
        tuple(t.toPython() if isinstance(t, Literal) else t for t in row)  # type: ignore[union-attr]
        for row in result
    ]


def test_construct_writes_turtle_by_default_and_ntriples_on_request(db: str) -> None:
    turtle = run("sparql", CONSTRUCT, db=db).stdout
    assert turtle.startswith("@prefix csg:")
    graph = rdflib.Graph().parse(data=turtle, format="turtle")
    assert sorted(str(o) for o in graph.objects()) == ["sink", "towel"]
    for fmt, parser in (("nt", "nt"), ("ntriples", "nt"), ("jsonld", "json-ld")):
        other = run("sparql", CONSTRUCT, "--format", fmt, db=db).stdout
        assert isomorphic(rdflib.Graph().parse(data=other, format=parser), graph)
    as_json = run("sparql", CONSTRUCT, "--json", db=db).stdout
    assert isomorphic(rdflib.Graph().parse(data=as_json, format="json-ld"), graph)


def test_ask_json_and_the_default_text(db: str) -> None:
    assert json.loads(run("sparql", "ASK { ?a csg:near ?b }", "--json", db=db).stdout) == {
        "head": {},
        "boolean": True,
    }
    assert run("sparql", "ASK { ?a csg:inside ?b }", db=db).stdout == "false\n"


def test_format_mismatches_are_one_line_errors(db: str, tmp_path: Path) -> None:
    assert_one_line_error(run("sparql", "ASK { ?a ?b ?c }", "--format", "csv", db=db,
                              check=False), "an ASK result cannot be written as 'csv'")  # fmt: skip
    assert_one_line_error(run("sparql", SELECT, "--format", "turtle", db=db, check=False),
                          "a SELECT result cannot be written as 'turtle'")  # fmt: skip
    assert_one_line_error(run("sparql", SELECT, "--format", "xml", "--json", db=db,
                              check=False), "--json and --format xml")  # fmt: skip


def test_a_truncated_result_says_so_on_stderr(db: str) -> None:
    proc = run("sparql", "SELECT ?s WHERE { ?s ?p ?o }", "--limit", "3", "--format", "tsv",
               db=db)  # fmt: skip
    assert proc.stdout.count("\n") == 4
    assert proc.stderr.strip() == "(truncated at 3 rows)"
