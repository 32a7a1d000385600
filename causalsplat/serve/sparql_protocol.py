"""``/sparql``: the query operation of the SPARQL 1.1 Protocol, read-only.

Requests (the three forms the protocol defines):

* ``GET /sparql?query=...``;
* ``POST /sparql`` with ``Content-Type: application/x-www-form-urlencoded`` and
  ``query=...`` in the body;
* ``POST /sparql`` with ``Content-Type: application/sparql-query`` and the query as the
  body.

The dataset holds each stored scene's RDF view (the triples of its Turtle export) as a
named graph, the scene's IRI, and their union as the default graph; ``scene=ID``
(repeatable, an extension) narrows it to some scenes. The query's ``FROM`` / ``FROM NAMED``
choose among those graphs, and ``default-graph-uri`` / ``named-graph-uri`` (repeatable)
replace the query's dataset, as the protocol says; nothing is ever loaded from elsewhere.
Updates (``update=``, ``using-graph-uri``, ``application/sparql-update``) and any query the
read-only guard refuses (``INSERT``, ``LOAD``, ``SERVICE``...) are answered 400: nothing in
the store changes. The answer's format is chosen from ``Accept`` (q-values honoured): for
SELECT and ASK the W3C SPARQL 1.1 Query Results JSON (the default), XML, CSV or TSV (CSV and
TSV for SELECT only); for CONSTRUCT and DESCRIBE Turtle (the default), N-Triples, JSON-LD,
RDF/XML, N-Quads, TriG or N3. A ``format`` or ``output`` parameter naming one of these
(``json``, ``xml``, ``csv``, ``tsv``, ``turtle``, ``ntriples``, ``jsonld``, ``rdfxml``,
``nquads``, ``trig``, ``n3``) takes precedence; 406
when nothing acceptable exists. The app's row limit and timeout bound every query: a
query giving more rows than the limit is refused with 400 naming the limit and how to page
(LIMIT/OFFSET), never cut silently; a query past its time is stopped and
answered 503.
"""

from __future__ import annotations

from urllib.parse import parse_qs

from causalsplat.serve.app import App, HttpError, Request, Response
from graph_store.rdf import query_kind
from graph_store.rdf.results import FORMATS_BY_KIND, MEDIA_TYPES

#: Media types clients send in ``Accept`` (beyond :data:`MEDIA_TYPES`), by query kind.
_ACCEPTED = {
    "select": {
        "application/sparql-results+json": "json",
        "application/json": "json",
        "text/javascript": "json",
        "application/javascript": "json",
        "application/sparql-results+xml": "xml",
        "application/xml": "xml",
        "text/xml": "xml",
        "text/csv": "csv",
        "text/tab-separated-values": "tsv",
    },
    "graph": {
        "text/turtle": "turtle",
        "application/turtle": "turtle",
        "application/x-turtle": "turtle",
        "application/n-triples": "ntriples",
        "text/plain": "ntriples",
        "application/ld+json": "jsonld",
        "application/x-json+ld": "jsonld",
        "application/json": "jsonld",
        "application/rdf+xml": "rdfxml",
        "application/xml": "rdfxml",
        "text/xml": "rdfxml",
        "application/n-quads": "nquads",
        "text/x-nquads": "nquads",
        "application/trig": "trig",
        "application/x-trig": "trig",
        "text/n3": "n3",
        "text/rdf+n3": "n3",
    },
}
_ACCEPTED["ask"] = {k: v for k, v in _ACCEPTED["select"].items() if v in ("json", "xml")}


def negotiate(kind: str, accept: str, explicit: list[str] | None = None) -> str | None:
    """The format to answer a ``kind`` query with, or ``None`` when none is acceptable.

    ``explicit``: values of ``format`` / ``output`` parameters; the first that names a
    format of this kind wins over ``accept``.

    >>> negotiate("select", "text/csv;q=0.5, application/sparql-results+xml")
    'xml'
    >>> negotiate("graph", "text/html, */*;q=0.1"), negotiate("ask", "text/csv") is None
    ('turtle', True)
    """
    allowed = FORMATS_BY_KIND[kind]
    for value in explicit or ():
        name = value.strip().lower()
        if name in allowed:
            return name
    if not accept.strip():
        return allowed[0]
    table = _ACCEPTED[kind]
    ranges = []
    for position, item in enumerate(accept.split(",")):
        media, *params = (p.strip() for p in item.split(";"))
        q = 1.0
        for param in params:
            name, _, value = param.partition("=")
            if name.strip().lower() == "q":
                try:
                    q = float(value)
                except ValueError:
                    q = 0.0
        if media and q > 0:
            ranges.append((-q, media.count("*"), position, media.lower()))
    for _q, _wild, _pos, media in sorted(ranges):
        if media == "*/*":
            return allowed[0]
        if media.endswith("/*"):
            main = media[:-1]
            found = next((f for f in allowed if MEDIA_TYPES[f].startswith(main)), None)
            if found is not None:
                return found
        elif media in table:
            return table[media]
    return None


def _query_params(request: Request) -> dict[str, list[str]]:
    """The protocol's parameters: the URL's, and a form body's for a form POST."""
    params = {k: list(v) for k, v in request.query.items()}
    if request.method != "POST":
        return params
    media = request.media_type
    if media == "application/x-www-form-urlencoded":
        try:
            form = parse_qs(request.body.decode("utf-8"), keep_blank_values=True, errors="strict")
        except UnicodeDecodeError:
            raise HttpError(400, "the form body is not UTF-8") from None
        for name, values in form.items():
            params.setdefault(name, []).extend(values)
    elif media == "application/sparql-query":
        try:
            text = request.body.decode("utf-8")
        except UnicodeDecodeError:
            raise HttpError(400, "the query body is not UTF-8") from None
        params.setdefault("query", []).append(text)
    elif media == "application/sparql-update":
        raise HttpError(400, "SPARQL updates are refused: the endpoint is read-only")
    else:
        raise HttpError(
            415,
            f"POST a query as application/sparql-query or application/x-www-form-urlencoded,"
            f" not {media or 'a body without Content-Type'}",
        )
    return params


def sparql(app: App, request: Request, params: dict[str, str]) -> Response:
    """Answer one SPARQL query (module docstring)."""
    query_params = _query_params(request)
    if "update" in query_params:
        raise HttpError(400, "SPARQL updates are refused: the endpoint is read-only")
    for name in ("using-graph-uri", "using-named-graph-uri"):
        if name in query_params:
            raise HttpError(400, f"{name} belongs to SPARQL updates: the endpoint is read-only")
    defaults = query_params.get("default-graph-uri")
    named = query_params.get("named-graph-uri")
    queries = query_params.get("query", [])
    if len(queries) != 1:
        raise HttpError(400, "give exactly one query parameter (query=...)")
    text = queries[0]
    kind = query_kind(text)  # 400 for updates, SERVICE, FROM and syntax errors
    explicit = query_params.get("format", []) + query_params.get("output", [])
    fmt = negotiate(kind, request.header("accept"), explicit)
    if fmt is None:
        offered = ", ".join(MEDIA_TYPES[f].split(";")[0] for f in FORMATS_BY_KIND[kind])
        raise HttpError(406, f"no acceptable format for this query; this one offers {offered}")
    scene_ids = query_params.get("scene") or None
    # the view's workers (graph_store.rdf.sparql.WORKERS) run queries side by side; one
    # more waits for a free worker within its timeout, then gets 503
    result = app.store.sparql(
        text, scene_ids=scene_ids, limit=app.limit, timeout_s=app.timeout_s,
        default_graphs=defaults, named_graphs=named,
    )  # fmt: skip
    if result.truncated:
        # a cut result would look complete to every standard client: refused instead
        raise HttpError(
            400,
            f"the query gives more than {app.limit} rows, this endpoint's limit: add LIMIT"
            f" (at most {app.limit}) and OFFSET to page through them",
        )
    response = Response(200, result.serialize(fmt).encode("utf-8"), MEDIA_TYPES[fmt])  # type: ignore[arg-type]
    response.headers["Vary"] = "Accept"
    response.headers["X-Row-Limit"] = str(app.limit)
    return response


def preflight(app: App, request: Request, params: dict[str, str]) -> Response:
    """A CORS preflight for ``/sparql``: allowed for the origins ``serve --cors`` names
    (the headers are added by :meth:`App.handle`), a plain 204 otherwise."""
    response = Response(204, b"", "text/plain")
    if app.cors_origin(request) is not None:
        response.headers["Access-Control-Allow-Methods"] = "GET, POST, OPTIONS"
        response.headers["Access-Control-Allow-Headers"] = "Content-Type, Accept"
        response.headers["Access-Control-Max-Age"] = "600"
    return response
