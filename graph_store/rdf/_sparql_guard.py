"""Admission of SPARQL text: parse it as a read-only query or refuse it with a typed error.

The text is parsed with rdflib's SPARQL 1.1 *query* grammar. Anything else is refused:

* update requests (``INSERT``, ``DELETE``, ``LOAD``, ``CLEAR``, ``DROP``, ``CREATE``, ``ADD``,
  ``MOVE``, ``COPY``, ``WITH``): :class:`SparqlForbiddenError`;
* ``SERVICE`` anywhere (it calls a remote endpoint): :class:`SparqlForbiddenError`;
* text that is not a query: :class:`SparqlSyntaxError` with the parser's position.

Dataset clauses (``FROM`` / ``FROM NAMED``) are admitted: they select among the view's
named graphs (one per scene) and never load a document (both engines are told not to).
"""

from __future__ import annotations

import re
import threading
from dataclasses import dataclass
from functools import lru_cache
from typing import Any, Literal

from graph_store.errors import SparqlForbiddenError, SparqlSyntaxError
from graph_store.rdf._sparql_text import mask_non_code
from graph_store.rdf.namespace import PREFIXES

QueryKind = Literal["select", "ask", "graph"]

_UPDATE_WORDS = ("INSERT", "DELETE", "LOAD", "CLEAR", "DROP", "CREATE", "ADD", "MOVE", "COPY")
_UPDATE_RE = re.compile(
    r"(?<![\w:?$@])(" + "|".join((*_UPDATE_WORDS, "WITH")) + r")(?![\w:])", re.IGNORECASE
)


@dataclass(frozen=True, slots=True)
class CheckedQuery:
    """A query admitted by :func:`check_query`.

    ``text``: the text as given; ``kind``: select / ask / graph (CONSTRUCT and DESCRIBE);
    ``select_all``: a ``SELECT *`` (its columns are then returned sorted by name);
    ``prepared``: rdflib's translated query (algebra), with the standard prefixes;
    ``dataset``: the query names its dataset (``FROM`` / ``FROM NAMED``).
    """

    text: str
    kind: QueryKind
    select_all: bool
    prepared: Any
    dataset: bool = False


#: The deepest nesting of ``{}``, ``()`` and ``[]`` read at all. rdflib's parser recurses
#: per level and reaches Python's recursion limit first (at about 35 nested groups or 25
#: nested parentheses: refused as nested too deeply); this bound refuses a pathological
#: query before the parser starts on it.
MAX_NESTING = 64
#: Held while rdflib parses and translates a query.
_PARSER = threading.Lock()


def nesting(text: str) -> int:
    """The deepest nesting of brackets in ``text``, outside string literals and comments.

    >>> nesting('SELECT * WHERE { ?s ?p ?o FILTER (STR(?o) = "{{{") }  # {{')
    3
    """
    depth = deepest = 0
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if c in "\"'":
            quote = c * 3 if text.startswith(c * 3, i) else c
            i += len(quote)
            while i < n and not text.startswith(quote, i):
                i += 2 if text[i] == "\\" else 1
            i += len(quote)
            continue
        if c == "#":
            end = text.find("\n", i)
            i = n if end < 0 else end
            continue
        if c in "{([":
            depth += 1
            deepest = max(deepest, depth)
        elif c in "})]":
            depth -= 1
        i += 1
    return deepest


@lru_cache(maxsize=256)
def check_query(text: str) -> CheckedQuery:
    """Parse ``text`` as a read-only SPARQL query, or raise (see the module docstring)."""
    if not isinstance(text, str):
        raise SparqlSyntaxError(f"a SPARQL query must be a string, got {type(text).__name__}")
    depth = nesting(text)
    if depth > MAX_NESTING:
        raise SparqlSyntaxError(
            f"the query nests groups {depth} levels deep; at most {MAX_NESTING} are read"
        )
    with _PARSER:  # rdflib's parser (pyparsing) keeps state between calls: one at a time
        return _parse(text)


def _parse(text: str) -> CheckedQuery:
    from pyparsing import ParseException
    from rdflib.plugins.sparql.algebra import translateQuery
    from rdflib.plugins.sparql.parser import parseQuery

    try:
        parsed = parseQuery(text)
    except ParseException as exc:
        _refuse_update(text)
        raise SparqlSyntaxError(f"SPARQL syntax error: {exc}") from None
    except RecursionError:  # a nesting the bound above let through, in another form
        raise SparqlSyntaxError("the query is nested too deeply to be read") from None
    body = parsed[1]
    if _contains_service(parsed):
        raise SparqlForbiddenError("SERVICE clauses are refused: queries never leave this process")
    try:
        prepared = translateQuery(parsed, initNs=dict(PREFIXES))
    except Exception as exc:  # rdflib raises bare Exception for unknown prefixes
        raise SparqlSyntaxError(f"SPARQL error: {exc}") from None
    if _contains_service(prepared.algebra):
        raise SparqlForbiddenError("SERVICE clauses are refused: queries never leave this process")
    kind: QueryKind
    if body.name == "SelectQuery":
        kind = "select"
    elif body.name == "AskQuery":
        kind = "ask"
    else:
        kind = "graph"
    select_all = kind == "select" and "projection" not in body
    return CheckedQuery(text=text, kind=kind, select_all=select_all, prepared=prepared,
                        dataset="datasetClause" in body)  # fmt: skip


def _refuse_update(text: str) -> None:
    """Raise SparqlForbiddenError when unparsable text reads as an update request."""
    from pyparsing import ParseException
    from rdflib.plugins.sparql.parser import parseUpdate

    code = mask_non_code(text)
    match = _UPDATE_RE.search(code)
    if match is None:
        try:
            update = parseUpdate(text)
        except ParseException:
            return
        if "request" not in update:
            return  # empty text or a prologue alone: not an update, not a query
    word = match.group(1).upper() if match else "update"
    raise SparqlForbiddenError(
        f"SPARQL {word} is refused: the SPARQL endpoint is read-only (queries only)"
    )


def _contains_service(node: Any) -> bool:
    """True when a parse tree or algebra contains a SERVICE pattern."""
    from rdflib.plugins.sparql.parserutils import CompValue

    stack = [node]
    seen: set[int] = set()
    while stack:
        item = stack.pop()
        if id(item) in seen:
            continue
        seen.add(id(item))
        if isinstance(item, CompValue):
            if item.name == "ServiceGraphPattern":
                return True
            stack.extend(item.values())
        elif isinstance(item, dict):
            stack.extend(item.values())
        elif isinstance(item, list | tuple):
            stack.extend(item)
        elif hasattr(item, "asList") and not isinstance(item, str):
            stack.extend(list(item))
    return False


def query_variables(query: CheckedQuery) -> frozenset[str]:
    """Every variable name the query mentions (patterns, filters, projections, groups)."""
    from rdflib.term import Variable

    found: set[str] = set()
    seen: set[int] = set()
    stack: list[Any] = [query.prepared.algebra]
    while stack:  # iterative: a deeply nested query cannot exhaust the recursion limit
        node = stack.pop()
        if isinstance(node, Variable):
            found.add(str(node))
        elif isinstance(node, dict | list | tuple | set | frozenset) and id(node) not in seen:
            seen.add(id(node))
            stack.extend(node.values() if isinstance(node, dict) else node)
    return frozenset(found)
