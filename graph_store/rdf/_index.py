"""A subject/predicate index over parsed triples, with typed, checked property reads.

Every read names the node and the property in its error, e.g.
``scene 's1', entity <.../entity/3>: csg:centroidX must be a finite number, got 'NaN'``.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable

from graph_store.errors import RDFFormatError
from graph_store.rdf._parse import RDF_LANG_STRING, XSD_STRING, Lit, Term, Triple
from graph_store.rdf.namespace import CSG, PREFIXES, csg_local_names

RDF_TYPE = PREFIXES["rdf"] + "type"
CSG_NS = str(CSG._NS)
_XSD = PREFIXES["xsd"]
_INTEGER_TYPES = frozenset(
    _XSD + t
    for t in [
        "integer",
        "int",
        "long",
        "short",
        "byte",
        "nonNegativeInteger",
        "positiveInteger",
        "nonPositiveInteger",
        "negativeInteger",
        "unsignedLong",
        "unsignedInt",
        "unsignedShort",
        "unsignedByte",
    ]
)
_NUMBER_TYPES = _INTEGER_TYPES | {_XSD + "double", _XSD + "float", _XSD + "decimal"}
_INTEGER_RE = re.compile(r"[+-]?[0-9]+\Z")
_NUMBER_RE = re.compile(r"[+-]?([0-9]+(\.[0-9]*)?|\.[0-9]+)([eE][+-]?[0-9]+)?\Z|[+-]?INF\Z|NaN\Z")
#: Every csg term, to refuse misspelt or unknown predicates and classes.
KNOWN_CSG_TERMS = frozenset(CSG_NS + name for name in csg_local_names())


def short(iri: str) -> str:
    """``csg:name`` for a term of a known namespace, else ``<iri>``."""
    for prefix, ns in PREFIXES.items():
        if iri.startswith(ns):
            return f"{prefix}:{iri[len(ns) :]}"
    return f"<{iri}>"


def show(term: Term) -> str:
    """A term as it would appear in N-Triples (for messages)."""
    if isinstance(term, Lit):
        if term.lang:
            return f"{term.lexical!r}@{term.lang}"
        return f"{term.lexical!r}^^{short(term.datatype)}"
    return term if term.startswith("_:") else f"<{term}>"


class TripleIndex:
    """``props[subject][predicate] -> [objects]`` and ``typed[class] -> [subjects]``."""

    def __init__(self, triples: Iterable[Triple]) -> None:
        props: dict[str, dict[str, list[Term]]] = {}
        typed: dict[str, list[str]] = {}
        checked: set[str] = {RDF_TYPE}
        for s, p, o in triples:
            by_pred = props.get(s)
            if by_pred is None:
                by_pred = props[s] = {}
            values = by_pred.get(p)
            if values is None:
                by_pred[p] = [o]
            else:
                values.append(o)
            if p not in checked:
                if p.startswith(CSG_NS) and p not in KNOWN_CSG_TERMS:
                    raise RDFFormatError(f"{show(s)}: unknown predicate {short(p)}")
                checked.add(p)
            elif p == RDF_TYPE and isinstance(o, str):
                typed.setdefault(o, []).append(s)
        for cls, subjects in typed.items():
            if cls.startswith(CSG_NS) and cls not in KNOWN_CSG_TERMS:
                raise RDFFormatError(f"{show(subjects[0])}: unknown class {short(cls)}")
        self.props = props
        self.typed = typed

    def of_type(self, cls: str) -> list[str]:
        return self.typed.get(cls, [])

    def values(self, node: str, prop: str) -> list[Term]:
        by_pred = self.props.get(node)
        return by_pred.get(prop, []) if by_pred else []

    def one(self, node: str, prop: str, where: str, *, required: bool) -> Term | None:
        values = self.values(node, prop)
        if len(values) > 1:
            shown = ", ".join(sorted(show(v) for v in values))
            raise RDFFormatError(f"{where}: {short(prop)} has {len(values)} values ({shown})")
        if not values:
            if required:
                raise RDFFormatError(f"{where}: missing required property {short(prop)}")
            return None
        return values[0]

    def opt_string(self, node: str, prop: str, where: str) -> str | None:
        value = self.one(node, prop, where, required=False)
        return None if value is None else _as_string(value, prop, where)

    def string(self, node: str, prop: str, where: str) -> str:
        return _as_string(self.one(node, prop, where, required=True), prop, where)

    def opt_integer(self, node: str, prop: str, where: str) -> int | None:
        value = self.one(node, prop, where, required=False)
        return None if value is None else _as_integer(value, prop, where)

    def integer(self, node: str, prop: str, where: str) -> int:
        return _as_integer(self.one(node, prop, where, required=True), prop, where)

    def opt_double(self, node: str, prop: str, where: str) -> float | None:
        value = self.one(node, prop, where, required=False)
        return None if value is None else _as_double(value, prop, where)

    def double(self, node: str, prop: str, where: str) -> float:
        return _as_double(self.one(node, prop, where, required=True), prop, where)

    def opt_node(self, node: str, prop: str, where: str) -> str | None:
        value = self.one(node, prop, where, required=False)
        return None if value is None else _as_node(value, prop, where)

    def node(self, node: str, prop: str, where: str) -> str:
        """An IRI or blank node value."""
        return _as_node(self.one(node, prop, where, required=True), prop, where)

    def nodes(self, node: str, prop: str, where: str) -> list[str]:
        return [_as_node(v, prop, where) for v in self.values(node, prop)]


def _as_string(value: Term | None, prop: str, where: str) -> str:
    if not isinstance(value, Lit) or value.datatype != XSD_STRING:
        kind = "a language-tagged string" if _is_lang(value) else _show_opt(value)
        raise RDFFormatError(f"{where}: {short(prop)} must be a plain string, got {kind}")
    return value.lexical


def _as_integer(value: Term | None, prop: str, where: str) -> int:
    if (
        not isinstance(value, Lit)
        or value.datatype not in _INTEGER_TYPES
        or not _INTEGER_RE.match(value.lexical)
    ):
        raise RDFFormatError(f"{where}: {short(prop)} must be an integer, got {_show_opt(value)}")
    return int(value.lexical)


def _as_double(value: Term | None, prop: str, where: str) -> float:
    if isinstance(value, Lit) and value.lexical.lower().lstrip("+-") in ("nan", "inf"):
        raise RDFFormatError(
            f"{where}: {short(prop)} must be a finite number, got {value.lexical!r}"
        )
    if (
        not isinstance(value, Lit)
        or value.datatype not in _NUMBER_TYPES
        or not _NUMBER_RE.match(value.lexical)
    ):
        raise RDFFormatError(f"{where}: {short(prop)} must be a number, got {_show_opt(value)}")
    number = float(value.lexical.replace("INF", "inf"))
    if not math.isfinite(number):
        raise RDFFormatError(
            f"{where}: {short(prop)} must be a finite number, got {value.lexical!r}"
        )
    return number


def _as_node(value: Term | None, prop: str, where: str) -> str:
    if not isinstance(value, str):
        raise RDFFormatError(f"{where}: {short(prop)} must be a node, got {_show_opt(value)}")
    return value


def _show_opt(value: Term | None) -> str:
    return "nothing" if value is None else show(value)


def _is_lang(value: Term | None) -> bool:
    return isinstance(value, Lit) and value.datatype == RDF_LANG_STRING
