"""Parse an RDF document into plain-Python triples (pyoxigraph, or rdflib as fallback).

Terms come back as: an IRI as ``str``; a blank node as ``"_:" + label`` (never an absolute
IRI, so the two cannot collide); a literal as :class:`Lit`. Neither parser reaches the
network: pyoxigraph refuses remote JSON-LD contexts, and the rdflib path checks JSON-LD
documents for context references before parsing.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from typing import Any, NamedTuple

from graph_store.errors import RDFFormatError

XSD_STRING = "http://www.w3.org/2001/XMLSchema#string"
RDF_LANG_STRING = "http://www.w3.org/1999/02/22-rdf-syntax-ns#langString"


class Lit(NamedTuple):
    """A literal: its lexical form, datatype IRI and language tag (or ``None``)."""

    lexical: str
    datatype: str
    lang: str | None = None


Term = str | Lit
Triple = tuple[str, str, Term]

_OX_FORMATS = {"turtle": "TURTLE", "ntriples": "N_TRIPLES", "jsonld": "JSON_LD"}
_RDFLIB_FORMATS = {"turtle": "turtle", "ntriples": "nt", "jsonld": "json-ld"}


def have_pyoxigraph() -> bool:
    try:
        import pyoxigraph  # noqa: F401
    except ImportError:
        return False
    return True


def parse_triples(data: bytes, fmt: str, *, engine: str | None = None) -> Iterator[Triple]:
    """The triples of a document in format ``fmt`` (``turtle``, ``ntriples``, ``jsonld``).

    ``engine``: ``"oxigraph"``, ``"rdflib"``, or ``None`` for pyoxigraph when installed.
    Iterating raises :class:`RDFFormatError` with the parser's message on malformed input.
    """
    if engine is None:
        engine = "oxigraph" if have_pyoxigraph() else "rdflib"
    if engine == "oxigraph":
        return _oxigraph_triples(data, fmt)
    if engine == "rdflib":
        return _rdflib_triples(data, fmt)
    raise ValueError(f"unknown RDF parser {engine!r}; expected 'oxigraph' or 'rdflib'")


def _oxigraph_triples(data: bytes, fmt: str) -> Iterator[Triple]:
    import pyoxigraph as ox

    rdf_format = getattr(ox.RdfFormat, _OX_FORMATS[fmt])
    named, blank, literal = ox.NamedNode, ox.BlankNode, ox.Literal
    try:
        for quad in ox.parse(data, format=rdf_format, without_named_graphs=True):
            s, o = quad.subject, quad.object
            kind = type(o)
            if kind is literal:
                datatype = o.datatype.value
                obj: Term = Lit(
                    o.value, datatype, o.language if datatype == RDF_LANG_STRING else None
                )
            elif kind is named:
                obj = o.value
            elif kind is blank:
                obj = "_:" + o.value
            else:
                raise RDFFormatError(f"unsupported RDF-star object {o}")
            kind = type(s)
            if kind is named:
                subject = s.value
            elif kind is blank:
                subject = "_:" + s.value
            else:
                raise RDFFormatError(f"unsupported RDF-star subject {s}")
            yield subject, quad.predicate.value, obj
    except (SyntaxError, ValueError, OSError) as exc:
        raise RDFFormatError(f"malformed {fmt} document: {exc}") from exc


def _rdflib_triples(data: bytes, fmt: str) -> Iterator[Triple]:
    from rdflib import BNode, Graph, URIRef
    from rdflib import Literal as RLiteral

    if fmt == "jsonld":
        _refuse_remote_contexts(data)
    g = Graph()
    try:
        g.parse(data=data, format=_RDFLIB_FORMATS[fmt])
    except Exception as exc:  # rdflib's parsers raise many unrelated exception types
        raise RDFFormatError(f"malformed {fmt} document: {exc}") from exc

    def term(t: Any) -> Term:
        if isinstance(t, URIRef):
            return str(t)
        if isinstance(t, BNode):
            return "_:" + str(t)
        if isinstance(t, RLiteral):
            if t.datatype is not None:
                return Lit(str(t), str(t.datatype), None)
            return Lit(str(t), RDF_LANG_STRING if t.language else XSD_STRING, t.language)
        raise RDFFormatError(f"unsupported RDF term {t!r}")

    for s, p, o in g:
        subject = term(s)
        if isinstance(subject, Lit):
            raise RDFFormatError(f"literal {subject.lexical!r} used as a subject")
        yield subject, str(p), term(o)


def _refuse_remote_contexts(data: bytes) -> None:
    """Refuse JSON-LD that references a context by IRI (the parser would fetch it)."""
    try:
        doc = json.loads(data)
    except ValueError as exc:
        raise RDFFormatError(f"malformed jsonld document: {exc}") from exc
    stack: list[Any] = [doc]
    while stack:
        item = stack.pop()
        if isinstance(item, dict):
            ctx = item.get("@context")
            refs = ctx if isinstance(ctx, list) else [ctx]
            if any(isinstance(r, str) for r in refs):
                raise RDFFormatError("JSON-LD documents with remote @context are not loaded")
            stack.extend(item.values())
        elif isinstance(item, list):
            stack.extend(item)
