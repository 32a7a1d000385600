"""The read-only SPARQL endpoint refuses updates and SERVICE, reads FROM as a choice among
its own graphs, and never opens a socket."""

from __future__ import annotations

import socket
from collections.abc import Iterator

import pytest

from graph_store import SparqlForbiddenError, SparqlSyntaxError
from graph_store.rdf import RdfView
from tests.strategies import random_scene

BACKENDS = ("oxigraph", "rdflib")

UPDATES = [
    "INSERT DATA { <http://a/s> <http://a/p> <http://a/o> }",
    "DELETE DATA { <http://a/s> <http://a/p> <http://a/o> }",
    "DELETE WHERE { ?s ?p ?o }",
    "PREFIX ex: <http://a/> INSERT { ?s ex:p 1 } WHERE { ?s ?p ?o }",
    "WITH <http://a/g> DELETE { ?s ?p ?o } WHERE { ?s ?p ?o }",
    "LOAD <http://127.0.0.1:9/data.ttl>",
    "LOAD SILENT <file:///etc/passwd> INTO GRAPH <http://a/g>",
    "CLEAR ALL",
    "CLEAR DEFAULT",
    "DROP GRAPH <http://a/g>",
    "CREATE GRAPH <http://a/g>",
    "ADD DEFAULT TO <http://a/g>",
    "MOVE DEFAULT TO <http://a/g>",
    "COPY DEFAULT TO <http://a/g>",
    "SELECT * WHERE { ?s ?p ?o } ; DROP ALL",
    "insert data { <http://a/s> <http://a/p> 'x' }",
]


@pytest.fixture(scope="module", params=BACKENDS)
def view(request: pytest.FixtureRequest) -> RdfView:
    return RdfView.from_graphs(random_scene("s", 20, 40, seed=0), backend=request.param)


@pytest.mark.parametrize("text", UPDATES)
def test_updates_are_refused(view: RdfView, text: str) -> None:
    before = len(view)
    with pytest.raises(SparqlForbiddenError, match="read-only"):
        view.query(text)
    assert len(view) == before


@pytest.mark.parametrize(
    "text",
    [
        "SELECT * WHERE { SERVICE <http://a/sparql> { ?s ?p ?o } }",
        "SELECT * WHERE { ?s ?p ?o OPTIONAL { SERVICE SILENT <http://a/sparql> { ?s ?q ?x } } }",
        "SELECT * WHERE { { SELECT ?s WHERE { SERVICE ?endpoint { ?s ?p ?o } } } }",
        "ASK { FILTER EXISTS { SERVICE <http://a/sparql> { ?s ?p ?o } } }",
        "CONSTRUCT { ?s ?p ?o } WHERE { SERVICE <http://a/sparql> { ?s ?p ?o } }",
    ],
)
def test_service_is_refused(view: RdfView, text: str) -> None:
    with pytest.raises(SparqlForbiddenError, match="SERVICE"):
        view.query(text)


@pytest.mark.parametrize(
    "text",
    [
        "SELECT * FROM <http://a/data.ttl> WHERE { ?s ?p ?o }",
        "SELECT * FROM NAMED <http://a/g> WHERE { GRAPH ?g { ?s ?p ?o } }",
        "ASK FROM <http://a/data.ttl> { ?s ?p ?o }",
        "CONSTRUCT { ?s ?p ?o } FROM <http://a/d> WHERE { ?s ?p ?o }",
        "DESCRIBE ?s FROM <http://a/d> WHERE { ?s ?p ?o }",
    ],
)
def test_dataset_clauses_name_graphs_the_view_does_not_hold(view: RdfView, text: str) -> None:
    """FROM / FROM NAMED choose among the view's graphs: an IRI it does not hold is an
    empty graph, never a document to fetch."""
    result = view.query(text)
    assert result.rows == () or result.boolean is False


@pytest.mark.parametrize(
    ("text", "where"),
    [
        ("SELECT * WHERE { ?s ?p }", "col:"),
        ("SELECT ?s WHERE { ?s ?p ?o ", "col:"),
        ("SELEKT ?s WHERE { ?s ?p ?o }", "col:"),
        ("", "col:"),
        ("SELECT * WHERE { ?s nope:p ?o }", "nope"),
        ("SELECT * WHERE { ?s ?p ?o } garbage", "col:29"),
        ("PREFIX ex: <http://a/>", "col:"),
    ],
)
def test_syntax_errors_say_where(view: RdfView, text: str, where: str) -> None:
    with pytest.raises(SparqlSyntaxError) as info:
        view.query(text)
    assert where in str(info.value)


def test_words_inside_strings_and_iris_are_not_updates(view: RdfView) -> None:
    # Unparsable text whose "update words" are all inside strings, IRIs or comments.
    with pytest.raises(SparqlSyntaxError):
        view.query('SELECT ?s WHERE { ?s ?p "INSERT DATA" <http://a/DROP> # LOAD\n')
    # and valid queries that mention them are answered
    result = view.query('SELECT ?s WHERE { ?s csg:category "INSERT" } # DROP ALL', bindings={})
    assert result.rows == ()


@pytest.fixture
def listening_port() -> Iterator[tuple[int, socket.socket]]:
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(8)
    server.setblocking(False)
    try:
        yield server.getsockname()[1], server
    finally:
        server.close()


@pytest.fixture
def no_connect(monkeypatch: pytest.MonkeyPatch) -> list[object]:
    """Record (and block) every outgoing connection attempt of this process."""
    attempts: list[object] = []

    def refuse(self: socket.socket, address: object) -> None:
        attempts.append(address)
        raise OSError("network access in a test")

    monkeypatch.setattr(socket.socket, "connect", refuse)
    monkeypatch.setattr(socket.socket, "connect_ex", refuse)
    return attempts


@pytest.mark.parametrize("backend", BACKENDS)
def test_nothing_reaches_a_listening_server(
    backend: str, listening_port: tuple[int, socket.socket], no_connect: list[object]
) -> None:
    port, server = listening_port
    url = f"http://127.0.0.1:{port}"
    view = RdfView.from_graphs(random_scene("s", 5, 5, seed=1), backend=backend)
    attempts = [
        f"SELECT * WHERE {{ SERVICE <{url}/sparql> {{ ?s ?p ?o }} }}",
        f"LOAD <{url}/data.ttl>",
        f"LOAD <{url}/data.ttl> INTO GRAPH <{url}/g>",
    ]
    for text in attempts:
        with pytest.raises(SparqlForbiddenError):
            view.query(text)
    for text in (
        f"SELECT * FROM <{url}/data.ttl> WHERE {{ ?s ?p ?o }}",
        f"SELECT * FROM NAMED <{url}/g> WHERE {{ GRAPH ?g {{ ?s ?p ?o }} }}",
    ):
        assert view.query(text, isolate=False).rows == ()  # an empty graph, nothing fetched
    assert no_connect == []
    with pytest.raises(BlockingIOError):
        server.accept()  # no connection is waiting
