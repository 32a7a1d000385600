"""A JSON-LD writer: one node object per subject, values typed as strings.

Every literal keeps its exact lexical form (``{"@value": "-0.0", "@type": "xsd:double"}``):
JSON-LD's native numbers would turn ``-0.0`` and ``5.0`` into ``xsd:integer`` values and
lose the double's exact text. Property names and classes are compacted with the standard
prefixes, which the document declares in its ``@context``.
"""

from __future__ import annotations

import json
from collections.abc import Iterable

from graph_store.rdf._parse import XSD_STRING, Lit, Term, Triple
from graph_store.rdf.namespace import PREFIXES

_RDF_TYPE = PREFIXES["rdf"] + "type"


def _compact(iri: str) -> str:
    for prefix, ns in PREFIXES.items():
        if iri.startswith(ns) and iri[len(ns) :].replace("_", "a").isalnum():
            return f"{prefix}:{iri[len(ns) :]}"
    return iri


def _node_ref(term: str) -> dict[str, str]:
    return {"@id": term}


def _value(term: Term) -> object:
    if not isinstance(term, Lit):
        return _node_ref(term)
    if term.lang is not None:
        return {"@value": term.lexical, "@language": term.lang}
    if term.datatype == XSD_STRING:
        return term.lexical
    return {"@value": term.lexical, "@type": _compact(term.datatype)}


def jsonld_from_triples(triples: Iterable[Triple]) -> str:
    """A JSON-LD document (compacted form with a prefix ``@context``) holding ``triples``."""
    nodes: dict[str, dict[str, object]] = {}
    for s, p, o in triples:
        node = nodes.get(s)
        if node is None:
            node = nodes[s] = {"@id": s}
        key: str
        value: object
        if p == _RDF_TYPE and isinstance(o, str):
            key, value = "@type", _compact(o)
        else:
            key, value = _compact(p), _value(o)
        existing = node.get(key)
        if existing is None:
            node[key] = value
        elif isinstance(existing, list):
            existing.append(value)
        else:
            node[key] = [existing, value]
    doc = {"@context": dict(PREFIXES), "@graph": list(nodes.values())}
    return json.dumps(doc, ensure_ascii=False, indent=1) + "\n"
