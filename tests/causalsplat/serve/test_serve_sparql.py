"""``/sparql`` through real SPARQL clients (SPARQLWrapper, rdflib's SPARQLStore) and plain
HTTP: the same rows as ``causalsplat sparql``, W3C formats, the read-only guard, the row
limit and the timeout."""

from __future__ import annotations

import io
import json
import subprocess
import sys
from pathlib import Path
from typing import Any
from urllib.parse import quote, urlencode

import pytest
import rdflib
from rdflib.compare import isomorphic
from rdflib.plugins.stores.sparqlstore import SPARQLStore
from rdflib.query import Result
from SPARQLWrapper import CSV, JSON, JSONLD, POST, POSTDIRECTLY, TSV, TURTLE, XML, SPARQLWrapper
from SPARQLWrapper.SPARQLExceptions import QueryBadFormed

from causalsplat import open_store
from causalsplat.serve import App, Server
from graph_store.rdf.iris import scene_iri
from tests.causalsplat.serve._client import request
from tests.conftest import COMMAND_TIMEOUT_S, REPO_ROOT

SELECT = (
    "SELECT ?thing ?category ?x WHERE { ?thing csg:supported_by ?t ; csg:category ?category ."
    " ?t csg:category 'kitchen counter' . ?thing csg:centroidX ?x } ORDER BY ?category"
)
CONSTRUCT = (
    "CONSTRUCT { ?a csg:supported_by ?b . ?a rdfs:label ?c } WHERE {"
    " ?a csg:supported_by ?b ; csg:category ?c }"
)
COUNT_TRIPLES = "SELECT (COUNT(*) AS ?n) WHERE { ?s ?p ?o }"
UPDATE = "INSERT DATA { <urn:x:a> <urn:x:b> <urn:x:c> }"


def cli(*args: str, db: str) -> str:
    proc = subprocess.run(
        [sys.executable, "-m", "causalsplat", "sparql", *args, "--db", db],
        capture_output=True, text=True, cwd=REPO_ROOT, timeout=COMMAND_TIMEOUT_S,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    return proc.stdout


@pytest.fixture(scope="module")
def cli_select(store_url: str) -> dict[str, Any]:
    """What ``causalsplat sparql --json`` answers to SELECT."""
    return json.loads(cli(SELECT, "--json", db=store_url))


@pytest.fixture(scope="module")
def endpoint(base_url: str) -> str:
    return f"{base_url}/sparql"


def _wrapper(endpoint: str, query: str, fmt: str, method: str = "GET") -> SPARQLWrapper:
    wrapper = SPARQLWrapper(endpoint)
    wrapper.setQuery(query)
    wrapper.setReturnFormat(fmt)
    if method != "GET":
        wrapper.setMethod(POST)
        if method == "POST-direct":
            wrapper.setRequestMethod(POSTDIRECTLY)
    return wrapper


@pytest.mark.parametrize("method", ["GET", "POST-form", "POST-direct"])
def test_sparqlwrapper_json_rows_are_the_cli_rows(
    endpoint: str, cli_select: dict[str, Any], method: str
) -> None:
    answer = _wrapper(endpoint, SELECT, JSON, method).queryAndConvert()
    assert answer == cli_select
    categories = [b["category"]["value"] for b in answer["results"]["bindings"]]
    assert categories == ["microwave", "microwave", "sink", "sink"]  # two stored scenes
    assert {b["thing"]["type"] for b in answer["results"]["bindings"]} == {"uri"}


def _rows_from_xml(document: Any) -> list[dict[str, tuple[str, str]]]:
    rows = []
    for result in document.getElementsByTagName("result"):
        row = {}
        for binding in result.getElementsByTagName("binding"):
            node = next(n for n in binding.childNodes if n.nodeType == n.ELEMENT_NODE)
            kind = {"uri": "uri", "literal": "literal", "bnode": "bnode"}[node.tagName]
            row[binding.getAttribute("name")] = (kind, node.firstChild.data)
        rows.append(row)
    return rows


def test_sparqlwrapper_xml_rows_are_the_cli_rows(endpoint: str, cli_select: dict[str, Any]) -> None:
    document = _wrapper(endpoint, SELECT, XML).queryAndConvert()
    expected = [{k: (v["type"], v["value"]) for k, v in b.items()}
                for b in cli_select["results"]["bindings"]]  # fmt: skip
    assert _rows_from_xml(document) == expected
    x = document.getElementsByTagName("literal")[1]
    assert x.getAttribute("datatype") == "http://www.w3.org/2001/XMLSchema#double"


@pytest.mark.parametrize("fmt", [XML, TURTLE, JSONLD])
def test_sparqlwrapper_construct_is_the_cli_graph(endpoint: str, store_url: str, fmt: str) -> None:
    expected = rdflib.Graph().parse(data=cli(CONSTRUCT, db=store_url), format="turtle")
    assert len(expected) > 10
    converted = _wrapper(endpoint, CONSTRUCT, fmt).queryAndConvert()
    if isinstance(converted, bytes):  # SPARQLWrapper hands Turtle back as text
        converted = rdflib.Graph().parse(data=converted, format="turtle")
    assert isomorphic(converted, expected)


def test_sparqlwrapper_ask(endpoint: str) -> None:
    assert _wrapper(endpoint, "ASK { ?a csg:near ?b }", JSON).queryAndConvert() == {
        "head": {},
        "boolean": True,
    }
    xml = _wrapper(endpoint, "ASK { ?a csg:inside ?a }", XML).queryAndConvert()
    assert xml.getElementsByTagName("boolean")[0].firstChild.data == "false"


@pytest.mark.parametrize("fmt", [CSV, TSV])
def test_sparqlwrapper_csv_and_tsv(endpoint: str, cli_select: dict[str, Any], fmt: str) -> None:
    text = _wrapper(endpoint, SELECT, fmt).queryAndConvert()
    parsed = Result.parse(io.BytesIO(text), format=fmt)
    rows = [[str(v) for v in row] for row in parsed]  # type: ignore[union-attr]
    expected = [[b[v]["value"] for v in cli_select["head"]["vars"]]
                for b in cli_select["results"]["bindings"]]  # fmt: skip
    if fmt == CSV:
        assert rows == expected
    else:  # TSV keeps the double's lexical form in its typed literal
        assert [r[:2] for r in rows] == [e[:2] for e in expected]
        assert [float(r[2]) for r in rows] == [float(e[2]) for e in expected]


@pytest.mark.parametrize("method", ["GET", "POST", "POST_FORM"])
def test_rdflib_sparqlstore_answers_as_the_cli(
    endpoint: str, store_url: str, cli_select: dict[str, Any], method: str
) -> None:
    graph = rdflib.Graph(store=SPARQLStore(endpoint, method=method))  # type: ignore[arg-type]
    rows = [tuple(row) for row in graph.query(SELECT)]  # type: ignore[arg-type]
    expected = Result.parse(io.BytesIO(json.dumps(cli_select).encode()), format="json")
    assert rows == [tuple(row) for row in expected]  # type: ignore[arg-type]
    assert graph.query("ASK { ?a csg:near ?b }").askAnswer is True
    constructed = graph.query(CONSTRUCT).graph
    assert constructed is not None
    reference = rdflib.Graph().parse(data=cli(CONSTRUCT, "--format", "nt", db=store_url),
                                     format="nt")  # fmt: skip
    assert isomorphic(constructed, reference)


@pytest.mark.parametrize(
    ("accept", "media"),
    [
        ("text/csv", "text/csv"),
        ("text/tab-separated-values", "text/tab-separated-values"),
        ("text/csv;q=0.2, application/sparql-results+xml;q=0.9", "application/sparql-results+xml"),
        ("text/html, */*;q=0.1", "application/sparql-results+json"),
        ("", "application/sparql-results+json"),
        ("application/json", "application/sparql-results+json"),
    ],
)
def test_accept_picks_the_result_format(endpoint: str, accept: str, media: str) -> None:
    reply = request(f"{endpoint}?{urlencode({'query': SELECT})}", headers={"Accept": accept})
    assert reply.status == 200 and reply.content_type.startswith(media)
    assert reply.headers["vary"] == "Accept"


def test_graph_formats_and_refusals_by_accept(endpoint: str) -> None:
    url = f"{endpoint}?{urlencode({'query': CONSTRUCT})}"
    graph_formats = [
        ("application/n-triples", "nt"),
        ("text/turtle", "turtle"),
        ("application/ld+json", "json-ld"),
    ]
    for accept, parser in graph_formats:
        reply = request(url, headers={"Accept": accept})
        assert reply.content_type.startswith(accept)
        assert len(rdflib.Graph().parse(data=reply.body, format=parser)) > 10
    assert request(url, headers={"Accept": "text/csv"}).status == 406
    ask = f"{endpoint}?{urlencode({'query': 'ASK { ?a ?b ?c }'})}"
    refused = request(ask, headers={"Accept": "text/csv"})
    assert refused.status == 406 and "application/sparql-results+json" in refused.json()["error"]
    by_param = request(f"{endpoint}?{urlencode({'query': SELECT, 'format': 'tsv'})}")
    assert by_param.content_type.startswith("text/tab-separated-values")


def _triple_count(endpoint: str) -> int:
    reply = request(f"{endpoint}?{urlencode({'query': COUNT_TRIPLES})}")
    return int(reply.json()["results"]["bindings"][0]["n"]["value"])


def test_updates_are_refused_and_change_nothing(endpoint: str, base_url: str) -> None:
    before = (_triple_count(endpoint), request(f"{base_url}/api/scenes").json())
    form = {"Content-Type": "application/x-www-form-urlencoded"}
    replies = [
        request(f"{endpoint}?{urlencode({'query': UPDATE})}"),
        request(endpoint, method="POST", body=urlencode({"update": UPDATE}).encode(), headers=form),
        request(endpoint, method="POST", body=urlencode({"query": UPDATE}).encode(), headers=form),
        request(
            endpoint,
            method="POST",
            body=UPDATE.encode(),
            headers={"Content-Type": "application/sparql-update"},
        ),
        request(
            endpoint,
            method="POST",
            body=UPDATE.encode(),
            headers={"Content-Type": "application/sparql-query"},
        ),
    ]
    for reply in replies:
        assert reply.status == 400
        assert "read-only" in reply.json()["error"]
    wrapper = _wrapper(endpoint, UPDATE, JSON, "POST-form")
    with pytest.raises(QueryBadFormed, match="read-only"):  # SPARQLWrapper's name for a 400
        wrapper.query()
    assert (_triple_count(endpoint), request(f"{base_url}/api/scenes").json()) == before


@pytest.mark.parametrize(
    ("params", "status", "words"),
    [
        ({}, 400, "exactly one query"),
        ({"query": "SELECT ?x WHERE { ?x"}, 400, "syntax"),
        ({"query": "SELECT * WHERE { SERVICE <http://127.0.0.1:9/> { ?s ?p ?o } }"}, 400,
         "SERVICE"),
        ({"query": COUNT_TRIPLES, "using-graph-uri": "urn:g"}, 400, "using-graph-uri"),
        ({"query": COUNT_TRIPLES, "default-graph-uri": "not an iri"}, 400, "absolute IRI"),
        ({"query": COUNT_TRIPLES, "scene": "nope"}, 404, "no scene 'nope'"),
    ],
)  # fmt: skip
def test_bad_queries_are_one_line_errors(
    endpoint: str, params: dict[str, str], status: int, words: str
) -> None:
    reply = request(f"{endpoint}?{urlencode(params)}")
    assert reply.status == status
    assert words in reply.json()["error"]


def test_post_needs_a_query_media_type(endpoint: str) -> None:
    reply = request(endpoint, method="POST", body=b"{}", headers={"Content-Type": "text/plain"})
    assert reply.status == 415


def test_scene_parameter_narrows_the_dataset(endpoint: str) -> None:
    both = _triple_count(endpoint)
    url = f"{endpoint}?{urlencode({'query': COUNT_TRIPLES, 'scene': 'demo-kitchen'})}"
    one = int(request(url).json()["results"]["bindings"][0]["n"]["value"])
    assert both == 2 * one


def test_a_result_past_the_row_limit_is_refused_and_pages_are_served(endpoint: str) -> None:
    # a cut result would look complete to SPARQLWrapper and rdflib: refused, naming how
    # to page (the fixture's limit is 50 rows)
    for text in ("SELECT ?s ?p ?o WHERE { ?s ?p ?o }", "CONSTRUCT WHERE { ?s ?p ?o }"):
        reply = request(f"{endpoint}?query={quote(text)}")
        assert reply.status == 400
        assert "more than 50 rows" in reply.json()["error"] and "OFFSET" in reply.json()["error"]
    seen: set[tuple[str, ...]] = set()
    for offset in range(0, 10_000, 50):
        page = f"SELECT ?s ?p ?o WHERE {{ ?s ?p ?o }} ORDER BY ?s ?p ?o LIMIT 50 OFFSET {offset}"
        reply = request(f"{endpoint}?query={quote(page)}")
        assert reply.status == 200 and reply.headers["x-row-limit"] == "50"
        rows = reply.json()["results"]["bindings"]
        seen |= {tuple(r[v]["value"] for v in ("s", "p", "o")) for r in rows}
        if len(rows) < 50:
            break
    assert len(seen) == _triple_count(endpoint)


def test_a_query_past_its_time_is_stopped_with_503(store_url: str) -> None:
    endless = "SELECT (COUNT(*) AS ?n) WHERE { ?a ?p ?x . ?b ?q ?y . ?c ?r ?z . ?d ?s ?w }"
    with (
        open_store(store_url, create=False) as store,
        Server(App(store, timeout_s=1.0), "127.0.0.1", 0).start() as server,
    ):
        reply = request(f"{server.url}sparql?{urlencode({'query': endless})}")
        assert reply.status == 503
        assert "did not finish within 1.0 s" in reply.json()["error"]
        # the same server answers the next query (on a new worker); a loaded machine may
        # take more than 1 s for that, so the next query gets a generous time
        server.app.timeout_s = COMMAND_TIMEOUT_S
        after = request(f"{server.url}sparql?{urlencode({'query': 'ASK { ?s ?p ?o }'})}")
        assert after.status == 200 and after.json()["boolean"] is True


def test_the_endpoint_serves_the_triples_of_the_export(
    endpoint: str, store_url: str, tmp_path: Path
) -> None:
    """Every triple of the Turtle export, relation evidence included, and no other: a query
    with a variable predicate sees the evidence as one naming csg:hasEvidence does."""
    out = tmp_path / "all.ttl"
    subprocess.run(
        [sys.executable, "-m", "causalsplat", "export", "--format", "turtle", "-o", str(out),
         "--db", store_url], check=True, capture_output=True, cwd=REPO_ROOT,
        timeout=COMMAND_TIMEOUT_S,
    )  # fmt: skip
    exported = rdflib.Graph().parse(out)
    by_predicate: dict[str, int] = {}
    for p in exported.predicates():
        by_predicate[str(p)] = by_predicate.get(str(p), 0) + 1
    # the fixture's server pages at 50 rows: the triples are compared per predicate
    query = "SELECT ?p (COUNT(*) AS ?n) WHERE { ?s ?p ?o } GROUP BY ?p"
    rows = _wrapper(endpoint, query, JSON).query().convert()["results"]["bindings"]
    served = {r["p"]["value"]: int(r["n"]["value"]) for r in rows}
    assert served == by_predicate
    assert any(p.endswith("#hasEvidence") for p in served)


def _count(endpoint: str, params: list[tuple[str, str]]) -> int:
    query = urlencode([("query", COUNT_TRIPLES), *params])
    body = json.loads(request(f"{endpoint}?{query}").body)
    return int(body["results"]["bindings"][0]["n"]["value"])


def test_scenes_are_named_graphs_and_the_protocol_dataset_selects_them(
    endpoint: str, store_url: str
) -> None:
    with open_store(store_url, create=False) as store:
        ids = sorted(s.scene_id for s in store.scenes())
    graphs = [scene_iri(s) for s in ids]
    per_graph = "SELECT ?g (COUNT(*) AS ?n) WHERE { GRAPH ?g { ?s ?p ?o } } GROUP BY ?g"
    rows = _wrapper(endpoint, per_graph, JSON).query().convert()["results"]["bindings"]
    sizes = {r["g"]["value"]: int(r["n"]["value"]) for r in rows}
    assert sorted(sizes) == sorted(graphs)
    total = _count(endpoint, [])
    assert total == sum(sizes.values())
    one = graphs[0]
    assert _count(endpoint, [("default-graph-uri", one)]) == sizes[one]
    assert _count(endpoint, [("default-graph-uri", g) for g in graphs]) == total
    assert _count(endpoint, [("named-graph-uri", one)]) == 0  # an empty default graph
    from_query = f"SELECT (COUNT(*) AS ?n) FROM <{one}> WHERE {{ ?s ?p ?o }}"
    rows = _wrapper(endpoint, from_query, JSON).query().convert()["results"]["bindings"]
    assert int(rows[0]["n"]["value"]) == sizes[one]
    # the command line takes the same dataset
    out = cli(COUNT_TRIPLES, "--default-graph", one, "--json", db=store_url)
    assert int(json.loads(out)["results"]["bindings"][0]["n"]["value"]) == sizes[one]
    # rdflib's SPARQLStore with a graph identifier sends it as default-graph-uri
    graph = rdflib.Graph(store=SPARQLStore(endpoint), identifier=rdflib.URIRef(one))  # type: ignore[arg-type]
    assert int(next(iter(graph.query(COUNT_TRIPLES)))[0]) == sizes[one]  # type: ignore[index]
    assert len(graph) == sizes[one]


@pytest.mark.parametrize(
    ("fmt", "media"),
    [("nquads", "application/n-quads"), ("trig", "application/trig"), ("n3", "text/n3")],
)
def test_construct_in_quad_and_n3_syntaxes(
    endpoint: str, store_url: str, fmt: str, media: str
) -> None:
    reference = rdflib.Graph().parse(data=cli(CONSTRUCT, "--format", "nt", db=store_url),
                                     format="nt")  # fmt: skip
    for how in ({"format": fmt}, {}):
        query = urlencode({"query": CONSTRUCT, **how})
        response = request(f"{endpoint}?{query}", headers={"Accept": media})
        assert response.headers["content-type"].startswith(media)
        parsed = rdflib.Dataset()
        parsed.parse(data=response.body.decode(), format=fmt)
        assert isomorphic(rdflib.Graph().parse(data=parsed.serialize(format="nt"), format="nt"),
                          reference)  # fmt: skip
