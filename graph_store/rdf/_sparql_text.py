"""Lexical helpers over SPARQL text: masking strings/IRIs/comments, and bindings as VALUES.

Bindings reach pyoxigraph as a ``VALUES`` block placed first in the query's outermost
group pattern, so that every pattern and ``FILTER`` of that group sees the bound values
(the same as rdflib's ``initBindings`` for all but variables used only in nested groups).
Terms are rendered from typed values with full escaping, never from raw user text.
"""

from __future__ import annotations

import re
from collections.abc import Mapping

from rdflib import Literal, URIRef

from graph_store.errors import SparqlError
from graph_store.rdf._terms import escape_string

# Long strings first, then short strings, IRIs and comments.
_NOT_CODE_RE = re.compile(
    r'"""(?:[^"\\]|\\.|"(?!""))*"""|'
    r"'''(?:[^'\\]|\\.|'(?!''))*'''|"
    r'"(?:[^"\\\n\r]|\\.)*"|'
    r"'(?:[^'\\\n\r]|\\.)*'|"
    r"<[^<>\"{}|^`\\\x00-\x20]*>|"
    r"#[^\n\r]*",
    re.DOTALL,
)
_FORM_RE = re.compile(r"(?<![\w:?$])(SELECT|ASK|CONSTRUCT|DESCRIBE)(?![\w:])", re.IGNORECASE)
_SUBSELECT_RE = re.compile(r"\s*SELECT(?![\w:])", re.IGNORECASE)
_IRI_FORBIDDEN_RE = re.compile(r'[<>"{}|^`\\\x00-\x20]')
_LANG_RE = re.compile(r"[a-zA-Z]+(-[a-zA-Z0-9]+)*\Z")


def mask_non_code(text: str) -> str:
    """``text`` with strings, IRIs and comments blanked out (same length, same offsets)."""
    return _NOT_CODE_RE.sub(lambda m: " " * len(m.group(0)), text)


def render_term(term: URIRef | Literal) -> str:
    """A term in SPARQL syntax; refuses IRIs and language tags that need escaping."""
    if isinstance(term, URIRef):
        return "<" + _checked_iri(str(term)) + ">"
    body = '"' + escape_string(str(term)) + '"'
    if term.language:
        if not _LANG_RE.match(term.language):
            raise SparqlError(f"invalid language tag {term.language!r} in a binding")
        return body + "@" + term.language
    if term.datatype is not None:
        return body + "^^<" + _checked_iri(str(term.datatype)) + ">"
    return body


def _checked_iri(iri: str) -> str:
    bad = _IRI_FORBIDDEN_RE.search(iri)
    if bad:
        raise SparqlError(f"IRI {iri!r} in a binding contains {bad.group(0)!r}")
    return iri


def _matching_close(masked: str, open_at: int) -> int | None:
    depth = 0
    for k in range(open_at, len(masked)):
        c = masked[k]
        if c == "{":
            depth += 1
        elif c == "}":
            depth -= 1
            if depth == 0:
                return k
    return None


def _outer_group(masked: str) -> int | None:
    """Offset of the ``{`` opening the query's WHERE pattern, or None (no WHERE pattern)."""
    form = _FORM_RE.search(masked)
    if form is None:
        return None
    i = form.end()
    if form.group(1).upper() == "CONSTRUCT":
        j = len(masked) - len(masked[i:].lstrip())
        if masked[j : j + 1] != "{":
            return None  # CONSTRUCT WHERE { ... }: the short form takes triples only
        close = _matching_close(masked, j)
        if close is None:
            return None
        i = close + 1
    depth = 0
    for k in range(i, len(masked)):
        c = masked[k]
        if c == "(":
            depth += 1
        elif c == ")":
            depth -= 1
        elif c == "{" and depth == 0:
            return k
    return None


def inject_values(text: str, terms: Mapping[str, URIRef | Literal]) -> str | None:
    """``text`` with a VALUES block of ``terms`` first in its WHERE pattern.

    Returns None when the query has no WHERE pattern to put it in.
    """
    masked = mask_non_code(text)
    open_at = _outer_group(masked)
    if open_at is None:
        return None
    close_at = _matching_close(masked, open_at)
    if close_at is None:
        return None
    names = " ".join("?" + name for name in terms)
    row = " ".join(render_term(t) for t in terms.values())
    values = f" VALUES ({names}) {{ ({row}) }} "
    if _SUBSELECT_RE.match(masked, open_at + 1):
        inner = text[open_at + 1 : close_at]
        return f"{text[: open_at + 1]}{values}{{{inner}}}{text[close_at:]}"
    return text[: open_at + 1] + values + text[open_at + 1 :]
