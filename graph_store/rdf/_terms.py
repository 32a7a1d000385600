"""Lexical forms of RDF terms for the streaming writers (Turtle and N-Triples).

Strings are escaped per the Turtle / N-Triples grammars (``STRING_LITERAL_QUOTE``):
``"``, ``\\``, line feed and carriage return must be escaped; every other control
character, and the Unicode line separators, are escaped too (``\\uXXXX``) so that no
line-oriented reader can split a literal. Doubles are written as ``repr(float)``, which
reads back to the same float exactly.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

from graph_store.rdf.namespace import BOT, CSG, GEO, PREFIXES
from graph_store.types import RelationType

XSD_NS = PREFIXES["xsd"]
RDF_TYPE = PREFIXES["rdf"] + "type"
RDFS_LABEL = PREFIXES["rdfs"] + "label"
XSD_DOUBLE = XSD_NS + "double"
XSD_INTEGER = XSD_NS + "integer"
WKT_LITERAL = str(GEO.wktLiteral)

_ESCAPES: dict[int, str] = {
    ord('"'): '\\"',
    ord("\\"): "\\\\",
    ord("\n"): "\\n",
    ord("\r"): "\\r",
    ord("\t"): "\\t",
    ord("\b"): "\\b",
    ord("\f"): "\\f",
}
for _code in [*range(0x20), 0x7F, 0x85, 0x2028, 0x2029]:
    _ESCAPES.setdefault(_code, f"\\u{_code:04X}")


def escape_string(text: str) -> str:
    """The body of a quoted string literal (without the quotes)."""
    return text.translate(_ESCAPES)


@lru_cache(maxsize=1 << 16)
def quoted(text: str) -> str:
    """A plain (``xsd:string``) literal: ``"escaped text"``."""
    return '"' + text.translate(_ESCAPES) + '"'


#: The csg properties the writers emit, by the name used in the token tables.
_CSG_PREDICATES = [
    "sceneId",
    "name",
    "units",
    "upAxis",
    "source",
    "configHash",
    "provenance",
    "key",
    "value",
    "inScene",
    "localId",
    "externalId",
    "category",
    "caption",
    "centroidX",
    "centroidY",
    "centroidZ",
    "minX",
    "minY",
    "minZ",
    "maxX",
    "maxY",
    "maxZ",
    "pointCount",
    "confidence",
    "hasAttribute",
    "attributeSource",
    "subject",
    "predicate",
    "object",
    "hasEvidence",
    "width",
    "height",
    "inView",
    "maskIndex",
    "assignedTo",
    "label",
    "score",
]


@dataclass(frozen=True, slots=True)
class Tokens:
    """Pre-rendered predicate and class tokens for one output format.

    ``p`` maps a csg property name (and ``"label"`` for ``rdfs:label``, ``"containsElement"``,
    ``"hasGeometry"``, ``"asWKT"``) to its token; ``rel`` maps a relation type value to the
    token of its property. ``*_types`` are lists of ``"predicate object"`` pairs stating
    ``rdf:type``. ``double_suffix`` closes a quoted double; ``integer`` writes an integer.
    """

    turtle: bool
    p: dict[str, str]
    rel: dict[str, str]
    scene_types: tuple[str, ...]
    entity_types: tuple[str, ...]
    geometry_type: str
    attribute_type: str
    assertion_type: str
    view_type: str
    mask_type: str
    double_suffix: str
    wkt_suffix: str

    def integer(self, value: int) -> str:
        return str(value) if self.turtle else f'"{value}"^^<{XSD_INTEGER}>'


def _iri_token(iri: str, turtle: bool) -> str:
    if turtle:
        for prefix, ns in PREFIXES.items():
            local = iri[len(ns) :]
            if iri.startswith(ns) and local.replace("_", "a").isalnum():
                return f"{prefix}:{local}"
    return f"<{iri}>"


def _type_pairs(turtle: bool, *classes: str) -> tuple[str, ...]:
    a = "a" if turtle else f"<{RDF_TYPE}>"
    objects = [_iri_token(c, turtle) for c in classes]
    if turtle:
        return (a + " " + ", ".join(objects),)
    return tuple(f"{a} {o}" for o in objects)


def make_tokens(turtle: bool) -> Tokens:
    """The token tables for Turtle (``turtle=True``) or N-Triples."""
    p = {name: _iri_token(str(CSG[name]), turtle) for name in _CSG_PREDICATES}
    p["rdfsLabel"] = _iri_token(RDFS_LABEL, turtle)
    p["containsElement"] = _iri_token(str(BOT.containsElement), turtle)
    p["hasGeometry"] = _iri_token(str(GEO.hasGeometry), turtle)
    p["asWKT"] = _iri_token(str(GEO.asWKT), turtle)
    rel = {t.value: _iri_token(str(CSG[t.value]), turtle) for t in RelationType}
    return Tokens(
        turtle=turtle,
        p=p,
        rel=rel,
        scene_types=_type_pairs(turtle, str(CSG.Scene), str(BOT.Space)),
        entity_types=_type_pairs(turtle, str(CSG.Entity), str(BOT.Element)),
        geometry_type=_type_pairs(turtle, str(GEO.Geometry))[0],
        attribute_type=_type_pairs(turtle, str(CSG.Attribute))[0],
        assertion_type=_type_pairs(turtle, str(CSG.RelationAssertion))[0],
        view_type=_type_pairs(turtle, str(CSG.View))[0],
        mask_type=_type_pairs(turtle, str(CSG.Mask))[0],
        double_suffix='"^^' + _iri_token(XSD_DOUBLE, turtle),
        wkt_suffix='"^^' + _iri_token(WKT_LITERAL, turtle),
    )


TURTLE = make_tokens(True)
NTRIPLES = make_tokens(False)


def turtle_header() -> str:
    """The ``@prefix`` lines of a Turtle document."""
    return "".join(f"@prefix {k}: <{v}> .\n" for k, v in PREFIXES.items()) + "\n"
