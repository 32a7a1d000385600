"""SPARQL text for each op, over the RDF mapping of :mod:`graph_store.rdf`.

Each step is one query that binds ``?e`` (the step's entities) and projects their
``csg:localId``. An input set appears as a pattern on a variable: the whole scene as
``?v a csg:Entity ; csg:inScene <scene>``, any other set as ``VALUES ?v { <iri> ... }``
holding the ids an earlier query returned (entity IRIs are minted only from integers).
Strings that reach the text are stored strings chosen in Python (see
:mod:`queries.semantics`), written as escaped literals by :func:`literal`; numbers are
written as typed ``xsd:double`` literals with ``repr``.
"""

from __future__ import annotations

from graph_store.rdf.iris import entity_iri, scene_iri
from graph_store.rdf.namespace import PREFIXES
from graph_store.types import RelationType
from queries.model import Op
from queries.semantics import Algebra

CSG = PREFIXES["csg"]
XSD_DOUBLE = PREFIXES["xsd"] + "double"
PROLOGUE = f"PREFIX csg: <{CSG}>\nPREFIX bot: <{PREFIXES['bot']}>\n"
SUPPORT_PATH = "(csg:supported_by|^csg:supports)"
XY = ("centroidX", "centroidY")
XYZ = ("centroidX", "centroidY", "centroidZ")
BOX = ("minX", "minY", "minZ", "maxX", "maxY", "maxZ")
#: Ops whose result is empty when any input is (the executors then send no query: rdflib
#: mis-evaluates some patterns that can have no solution).
EMPTY_IN_EMPTY_OUT = frozenset(
    {
        Op.FILTER_CATEGORY, Op.FILTER_ATTRIBUTE, Op.FILTER_AFFORDANCE, Op.MATCH_TEXT,
        Op.RELATE, Op.RELATE_BETWEEN, Op.ARGMIN, Op.ARGMAX, Op.MIDDLE, Op.INTERSECT,
        Op.SUPPORT_CLOSURE, Op.FALL_IF_REMOVED,
    }
)  # fmt: skip

_ECHAR = {
    ord("\\"): "\\\\",
    ord('"'): '\\"',
    ord("\n"): "\\n",
    ord("\r"): "\\r",
    ord("\t"): "\\t",
    ord("\b"): "\\b",
    ord("\f"): "\\f",
}


def literal(text: str) -> str:
    """A SPARQL string literal for ``text``.

    Quote, backslash and line breaks use the grammar's ``ECHAR`` escapes; other characters
    are written as they are (``\\uXXXX`` escapes would be decoded before parsing, so they
    cannot protect a quote).
    """
    return '"' + text.translate(_ECHAR) + '"'


def double(value: float) -> str:
    """A typed ``xsd:double`` literal that reads back as exactly ``value``."""
    return f'"{float(value)!r}"^^<{XSD_DOUBLE}>'


class SparqlAlgebra(Algebra[str, str]):
    """The semantics' algebra as fully parenthesised SPARQL expressions."""

    def const(self, value: float) -> str:
        return double(value)

    def add(self, a: str, b: str) -> str:
        return f"({a} + {b})"

    def sub(self, a: str, b: str) -> str:
        return f"({a} - {b})"

    def mul(self, a: str, b: str) -> str:
        return f"({a} * {b})"

    def div(self, a: str, b: str) -> str:
        return f"({a} / {b})"

    def neg(self, a: str) -> str:
        return f"(-{a})"

    def abs(self, a: str) -> str:
        return f"ABS({a})"

    def lt(self, a: str, b: str) -> str:
        return f"({a} < {b})"

    def le(self, a: str, b: str) -> str:
        return f"({a} <= {b})"

    def gt(self, a: str, b: str) -> str:
        return f"({a} > {b})"

    def ge(self, a: str, b: str) -> str:
        return f"({a} >= {b})"

    def all(self, *conditions: str) -> str:
        return "(" + " && ".join(conditions) + ")"

    def select(self, condition: str, a: str, b: str) -> str:
        return f"IF({condition}, {a}, {b})"


SPARQL = SparqlAlgebra()


class Patterns:
    """Pattern builders for one scene.

    Query shapes matter to the engines: a sub-``SELECT`` that starts from the smaller input
    and is then joined with the other inputs keeps Oxigraph from crossing two ``VALUES``
    blocks before it looks at a triple (tens of times slower at 1,000 x 1,000).
    """

    def __init__(self, scene_id: str) -> None:
        self.scene_id = scene_id
        self.scene = f"<{scene_iri(scene_id)}>"
        self.entity_prefix = entity_iri(scene_id, 0)[:-1]

    def iri(self, entity_id: int) -> str:
        return f"<{self.entity_prefix}{int(entity_id)}>"

    def in_scene(self, var: str) -> str:
        """``?var`` ranges over the scene's entities."""
        return f"{self.scene} bot:containsElement ?{var} .\n"

    def members(self, var: str, ids: frozenset[int] | None) -> str:
        """``?var`` ranges over ``ids`` (``None``: the whole scene)."""
        if ids is None:
            return self.in_scene(var)
        return values(f"?{var}", [self.iri(i) for i in sorted(ids)])

    def iri_list(self, ids: set[int] | frozenset[int]) -> str:
        return ", ".join(self.iri(i) for i in sorted(ids))

    @staticmethod
    def coords(var: str, *props: str) -> str:
        """``?var csg:centroidX ?var_centroidX ; ...`` for the given properties."""
        return f"?{var} " + " ; ".join(f"csg:{p} ?{var}_{p}" for p in props) + " .\n"

    @staticmethod
    def relation(subject: str, rel: RelationType, anchor: str) -> str:
        """``subject rel anchor`` stored either way round (``anchor inverse(rel) subject``)."""
        return (
            f"{{ ?{subject} csg:{rel.value} ?{anchor} }} UNION "
            f"{{ ?{anchor} csg:{rel.inverse.value} ?{subject} }}\n"
        )

    def entity_id(self, iri: str) -> int:
        """The local id in an entity IRI of this scene."""
        if not iri.startswith(self.entity_prefix):
            raise ValueError(f"{iri!r} is not an entity of scene {self.scene_id!r}")
        return int(iri[len(self.entity_prefix) :])


#: A pattern with no solutions (rdflib mis-evaluates an empty ``VALUES`` block and
#: ``FILTER (false)``).
NOTHING = "FILTER (1 = 0)\n"


def values(variables: str, rows: list[str]) -> str:
    """``VALUES variables { rows }``, or a pattern with no solutions when ``rows`` is empty."""
    if not rows:
        return NOTHING
    return f"VALUES {variables} {{ {' '.join(rows)} }}\n"


def sub_select(variables: str, body: str) -> str:
    """``{ SELECT variables WHERE { body } }``: evaluated first, then joined."""
    return f"{{ SELECT {variables} WHERE {{\n{body}}} }}\n"


def smallest_per_entity(value: str, body: str, condition: str) -> str:
    """``?v``, the smallest ``value`` over the solutions of ``body`` that meet
    ``condition``, per entity ``?e`` (with its ``?e_localId``), for ``argmin`` / ``argmax``
    / ``middle`` against reference sets. An aggregate over no solution yields one unbound
    row, which ``BOUND`` drops (see the executors' ``_match_text``)."""
    return (
        f"{{ SELECT ?e ?e_localId (MIN({value}) AS ?v) WHERE {{\n{body}FILTER {condition}\n}}"
        " GROUP BY ?e ?e_localId }\nFILTER (BOUND(?e))\n"
    )


def select_entities(body: str, *, distinct: bool = True) -> str:
    """``SELECT [DISTINCT] ?e`` of the entities bound by ``body``."""
    head = "SELECT DISTINCT ?e" if distinct else "SELECT ?e"
    return f"{PROLOGUE}{head} WHERE {{\n{body}}}"
