r"""W3C documents of SPARQL results: the SPARQL 1.1 Query Results formats and RDF graphs.

* SELECT and ASK: SPARQL 1.1 Query Results JSON (``application/sparql-results+json``) and
  XML (``application/sparql-results+xml``); SELECT also CSV (``text/csv``: IRIs and
  lexical forms only, lossy by the standard's design) and TSV
  (``text/tab-separated-values``: terms in SPARQL syntax, lossless). The standard gives
  ASK no CSV or TSV form.
* CONSTRUCT and DESCRIBE: the graph as Turtle (with the standard prefixes), N-Triples,
  JSON-LD (:mod:`graph_store.rdf._jsonld`), RDF/XML (through rdflib), or the graph as the
  default graph of N-Quads, TriG or N3 (whose syntaxes take N-Triples and Turtle as they
  are).

Every writer works from the result's typed terms (:attr:`SparqlResult.terms`), so an IRI
and a string that spells one stay apart, literals keep their datatype, language tag and
exact lexical form, and both SPARQL engines give the same document.

>>> from graph_store.rdf._parse import Lit
>>> from graph_store.rdf.sparql import SparqlResult
>>> r = SparqlResult("select", ("x", "n"), (), terms=(
...     ("http://example.org/a", Lit("1", "http://www.w3.org/2001/XMLSchema#integer")),
...     ("_:b0", None)))
>>> print(serialize_result(r, "json"))  # doctest: +NORMALIZE_WHITESPACE
{"head": {"vars": ["x", "n"]}, "results": {"bindings": [{"x": {"type": "uri", "value":
"http://example.org/a"}, "n": {"type": "literal", "value": "1", "datatype":
"http://www.w3.org/2001/XMLSchema#integer"}}, {"x": {"type": "bnode", "value": "b0"}}]}}
>>> serialize_result(r, "tsv").splitlines()[1:]
['<http://example.org/a>\t"1"^^<http://www.w3.org/2001/XMLSchema#integer>', '_:b0\t']
"""

from __future__ import annotations

import csv
import io
import json
import re
from collections.abc import Iterable, Iterator
from typing import TYPE_CHECKING, Any
from xml.sax.saxutils import escape, quoteattr

from graph_store.errors import SparqlFormatError
from graph_store.rdf._parse import XSD_STRING, Lit, Term
from graph_store.rdf._terms import escape_string, turtle_header
from graph_store.rdf.namespace import PREFIXES

if TYPE_CHECKING:
    from graph_store.rdf.sparql import SparqlResult

#: The media type of each format.
MEDIA_TYPES = {
    "json": "application/sparql-results+json",
    "xml": "application/sparql-results+xml",
    "csv": "text/csv; charset=utf-8",
    "tsv": "text/tab-separated-values; charset=utf-8",
    "turtle": "text/turtle; charset=utf-8",
    "ntriples": "application/n-triples",
    "jsonld": "application/ld+json",
    "rdfxml": "application/rdf+xml",
    "nquads": "application/n-quads",
    "trig": "application/trig; charset=utf-8",
    "n3": "text/n3; charset=utf-8",
}
#: The formats of each kind of result, its default first.
FORMATS_BY_KIND = {
    "select": ("json", "xml", "csv", "tsv"),
    "ask": ("json", "xml"),
    "graph": ("turtle", "ntriples", "jsonld", "rdfxml", "nquads", "trig", "n3"),
}
_KIND_NAMES = {"select": "a SELECT", "ask": "an ASK", "graph": "a CONSTRUCT/DESCRIBE"}

_IRI_ESCAPE_RE = re.compile(r'[<>"{}|^`\\\x00-\x20]')
_LABEL_RE = re.compile(r"[A-Za-z0-9_]+\Z")
_LOCAL_RE = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
# Characters XML 1.0 cannot hold, even escaped.
_NOT_XML_RE = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ufffe\uffff\ud800-\udfff]")
_RESULTS_NS = "http://www.w3.org/2005/sparql-results#"


def formats_for(kind: str) -> tuple[str, ...]:
    """The format names a result of ``kind`` (select, ask, graph) can be written in."""
    return FORMATS_BY_KIND[kind]


def serialize_result(result: SparqlResult, format: str | None = None) -> str:
    """``result`` as a document in ``format`` (default: ``json`` for SELECT and ASK,
    ``turtle`` for graphs); see the module docstring and :meth:`SparqlResult.serialize`."""
    allowed = FORMATS_BY_KIND[result.kind]
    if format is None:
        format = allowed[0]
    if format not in allowed:
        known = "" if format in MEDIA_TYPES else " (unknown format)"
        raise SparqlFormatError(
            f"{_KIND_NAMES[result.kind]} result cannot be written as {format!r}{known};"
            f" use one of: {', '.join(allowed)}"
        )
    if result.kind == "graph":
        triples = [_triple(row) for row in result.terms]
        if format in ("turtle", "trig", "n3"):
            return _turtle(triples)
        if format in ("ntriples", "nquads"):
            return "".join(_nt_line(t) for t in _relabelled(triples))
        if format == "jsonld":
            from graph_store.rdf._jsonld import jsonld_from_triples

            return jsonld_from_triples(triples)
        return _rdfxml(triples)
    if format == "json":
        return _json(result)
    if format == "xml":
        return _xml(result)
    if format == "csv":
        return _csv(result)
    return _tsv(result)


# -- SPARQL 1.1 Query Results -------------------------------------------------------------


def _json_term(term: Term) -> dict[str, str]:
    if isinstance(term, Lit):
        out = {"type": "literal", "value": term.lexical}
        if term.lang is not None:
            out["xml:lang"] = term.lang
        elif term.datatype != XSD_STRING:
            out["datatype"] = term.datatype
        return out
    if term.startswith("_:"):
        return {"type": "bnode", "value": term[2:]}
    return {"type": "uri", "value": term}


def _json(result: SparqlResult) -> str:
    if result.kind == "ask":
        return json.dumps({"head": {}, "boolean": bool(result.boolean)}) + "\n"
    columns = result.columns
    bindings = [
        {name: _json_term(t) for name, t in zip(columns, row) if t is not None}
        for row in result.terms
    ]
    document = {"head": {"vars": list(columns)}, "results": {"bindings": bindings}}
    return json.dumps(document, ensure_ascii=False) + "\n"


def _xml_text(text: str) -> str:
    bad = _NOT_XML_RE.search(text)
    if bad:
        raise SparqlFormatError(
            f"the result holds the character U+{ord(bad.group(0)):04X}, which XML cannot"
            " hold: ask for JSON or TSV instead"
        )
    return escape(text)


def _xml_term(term: Term) -> str:
    if isinstance(term, Lit):
        if term.lang is not None:
            attr = f" xml:lang={quoteattr(term.lang)}"
        elif term.datatype != XSD_STRING:
            attr = f" datatype={quoteattr(_xml_text(term.datatype))}"
        else:
            attr = ""
        return f"<literal{attr}>{_xml_text(term.lexical)}</literal>"
    if term.startswith("_:"):
        return f"<bnode>{_xml_text(term[2:])}</bnode>"
    return f"<uri>{_xml_text(term)}</uri>"


def _xml(result: SparqlResult) -> str:
    out = ['<?xml version="1.0" encoding="utf-8"?>\n', f'<sparql xmlns="{_RESULTS_NS}">\n']
    if result.kind == "ask":
        out.append("  <head/>\n")
        out.append(f"  <boolean>{'true' if result.boolean else 'false'}</boolean>\n")
    else:
        out.append("  <head>\n")
        out.extend(f"    <variable name={quoteattr(name)}/>\n" for name in result.columns)
        out.append("  </head>\n  <results>\n")
        for row in result.terms:
            out.append("    <result>\n")
            for name, term in zip(result.columns, row):
                if term is not None:
                    out.append(
                        f"      <binding name={quoteattr(name)}>{_xml_term(term)}</binding>\n"
                    )
            out.append("    </result>\n")
        out.append("  </results>\n")
    out.append("</sparql>\n")
    return "".join(out)


def _csv(result: SparqlResult) -> str:
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\r\n")
    writer.writerow(result.columns)
    for row in result.terms:
        writer.writerow(["" if t is None else t.lexical if isinstance(t, Lit) else t for t in row])
    return buffer.getvalue()


def _tsv(result: SparqlResult) -> str:
    lines = ["\t".join("?" + name for name in result.columns)]
    for row in result.terms:
        lines.append("\t".join("" if t is None else _term_syntax(t, {}) for t in row))
    return "\n".join(lines) + "\n"


# -- RDF graphs ---------------------------------------------------------------------------


def _triple(row: tuple[Term | None, ...]) -> tuple[str, str, Term]:
    s, p, o = row
    if not isinstance(s, str) or not isinstance(p, str) or o is None:  # pragma: no cover
        raise SparqlFormatError(f"not an RDF triple: {row!r}")
    return s, p, o


def _iri(iri: str) -> str:
    return "<" + _IRI_ESCAPE_RE.sub(lambda m: f"\\u{ord(m.group(0)):04X}", iri) + ">"


def _term_syntax(term: Term, prefixes: dict[str, str]) -> str:
    """A term in Turtle / N-Triples / SPARQL syntax (``prefixes``: namespace to prefix)."""
    if isinstance(term, Lit):
        body = '"' + escape_string(term.lexical) + '"'
        if term.lang is not None:
            return f"{body}@{term.lang}"
        if term.datatype == XSD_STRING:
            return body
        return f"{body}^^{_name(term.datatype, prefixes)}"
    if term.startswith("_:"):
        return term
    return _name(term, prefixes)


def _name(iri: str, prefixes: dict[str, str]) -> str:
    for namespace, prefix in prefixes.items():
        if iri.startswith(namespace) and _LOCAL_RE.match(iri[len(namespace) :]):
            return f"{prefix}:{iri[len(namespace) :]}"
    return _iri(iri)


def _relabelled(triples: Iterable[tuple[str, str, Term]]) -> Iterator[tuple[str, str, Term]]:
    """The triples with blank node labels that both Turtle and N-Triples accept."""
    labels: dict[str, str] = {}

    def label(term: Term) -> Term:
        if isinstance(term, Lit) or not term.startswith("_:") or _LABEL_RE.match(term[2:]):
            return term
        return labels.setdefault(term, f"_:b{len(labels)}")

    for s, p, o in triples:
        subject = label(s)
        assert isinstance(subject, str)
        yield subject, p, label(o)


def _nt_line(triple: tuple[str, str, Term]) -> str:
    s, p, o = triple
    return f"{_term_syntax(s, {})} {_iri(p)} {_term_syntax(o, {})} .\n"


def _turtle(triples: list[tuple[str, str, Term]]) -> str:
    prefixes = {ns: prefix for prefix, ns in PREFIXES.items()}
    by_subject: dict[str, list[str]] = {}
    for s, p, o in _relabelled(triples):
        predicate = "a" if p == PREFIXES["rdf"] + "type" else _name(p, prefixes)
        by_subject.setdefault(s, []).append(f"{predicate} {_term_syntax(o, prefixes)}")
    out = [turtle_header()]
    for subject, pairs in by_subject.items():
        out.append(f"{_term_syntax(subject, prefixes)} " + " ;\n    ".join(pairs) + " .\n")
    return "".join(out)


def _rdfxml(triples: list[tuple[str, str, Term]]) -> str:
    from rdflib import BNode, Graph, Literal, URIRef

    graph = Graph()
    for prefix, namespace in PREFIXES.items():
        graph.bind(prefix, namespace)

    def node(term: Term) -> Any:
        if isinstance(term, Lit):
            if term.lang is not None:
                return Literal(term.lexical, lang=term.lang, normalize=False)
            datatype = None if term.datatype == XSD_STRING else URIRef(term.datatype)
            return Literal(term.lexical, datatype=datatype, normalize=False)
        return BNode(term[2:]) if term.startswith("_:") else URIRef(term)

    for s, p, o in triples:  # XML 1.0 cannot hold some characters, escaped or not
        for term in (s, p, o):
            _xml_text(term.lexical if isinstance(term, Lit) else term)
        graph.add((node(s), URIRef(p), node(o)))
    try:
        text: str = graph.serialize(format="xml")
    except Exception as exc:  # rdflib: a predicate IRI that cannot be split into a QName
        raise SparqlFormatError(f"the graph cannot be written as RDF/XML: {exc}") from exc
    return text
