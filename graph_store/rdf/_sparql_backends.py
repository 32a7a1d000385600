"""The two SPARQL engines behind :class:`~graph_store.rdf.sparql.RdfView`.

Both evaluate an admitted query (:class:`CheckedQuery`) with typed bindings and consume at
most ``limit + 1`` results, checking a cancel flag between results; both hand back the
same typed terms (an IRI as ``str``, a blank node as ``"_:label"``, a literal as
:class:`~graph_store.rdf._parse.Lit`), which :func:`term_value` turns into the same Python
values, so their answers compare equal.

* :class:`OxigraphBackend`: an in-memory pyoxigraph ``Store`` bulk-loaded from the
  N-Triples writer, each scene into its named graph; bindings go in as a ``VALUES`` block
  of escaped, typed terms placed first in the WHERE pattern (pyoxigraph's SEP-0007
  substitutions only accept projected variables; they are used for queries without a
  WHERE pattern).
* :class:`RdflibBackend`: an rdflib ``Dataset`` on a memory store whose triple lookups stop
  the evaluation once its query is cancelled; bindings go in as ``initBindings``.

The dataset is the same on both: each scene's triples in the named graph of the scene's IRI
(:func:`~graph_store.rdf.iris.scene_iri`), and their union as the default graph unless the
query names its own (``FROM`` / ``FROM NAMED``: the named graphs it selects, never a
document loaded). On oxigraph a :data:`Selection` (the protocol's ``default-graph-uri`` and
``named-graph-uri``) replaces the query's dataset.
"""

from __future__ import annotations

import re
import threading
from collections.abc import Generator, Iterable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

from rdflib import BNode, Literal, URIRef, Variable
from rdflib.plugins.stores.memory import Memory

from graph_store.errors import SparqlArgumentError, SparqlError, SparqlSyntaxError
from graph_store.rdf._parse import RDF_LANG_STRING, Lit, Term
from graph_store.rdf._sparql_guard import CheckedQuery, QueryKind
from graph_store.rdf._sparql_text import inject_values
from graph_store.rdf.namespace import PREFIXES
from graph_store.types import SceneGraph

_XSD = PREFIXES["xsd"]
_INTEGER_TYPES = frozenset(
    _XSD + t
    for t in (
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
    )
)
_FLOAT_TYPES = frozenset({_XSD + "double", _XSD + "float", _XSD + "decimal"})
_BOOLEAN = _XSD + "boolean"
_XSD_STRING = _XSD + "string"
_INT_RE = re.compile(r"\s*[+-]?[0-9]+\s*\Z")
GRAPH_COLUMNS = ("subject", "predicate", "object")

#: A dataset given beside the query (the SPARQL protocol's ``default-graph-uri`` and
#: ``named-graph-uri``): (default graph IRIs, named graph IRIs); ``None``: the query's own.
Selection = tuple[tuple[str, ...], tuple[str, ...]] | None


class QueryCancelled(BaseException):
    """Raised inside an abandoned evaluation to stop it (never reaches callers)."""


@dataclass(frozen=True, slots=True)
class RawResult:
    """What a backend hands back: rows of terms (``None``: unbound), at most ``limit + 1``."""

    kind: QueryKind
    columns: tuple[str, ...]
    rows: list[tuple[Term | None, ...]]
    boolean: bool | None


def literal_value(lexical: str, datatype: str | None) -> object:
    """The Python value of a literal: int, float, bool or str (the lexical form otherwise)."""
    if datatype in _INTEGER_TYPES and _INT_RE.match(lexical):
        return int(lexical)
    if datatype in _FLOAT_TYPES:
        try:
            return float(lexical)
        except ValueError:
            return lexical
    if datatype == _BOOLEAN and lexical in ("true", "false", "1", "0"):
        return lexical in ("true", "1")
    return lexical


def term_value(term: Term | None) -> object:
    """The Python value of a result term (see :attr:`~graph_store.rdf.SparqlResult.rows`)."""
    if type(term) is Lit:
        if term.datatype == _XSD_STRING or term.lang is not None:
            return term.lexical
        return literal_value(term.lexical, term.datatype)
    return term


def _take(
    items: Iterable[tuple[Term | None, ...]], limit: int, cancel: threading.Event
) -> list[Any]:
    rows = []
    for row in items:
        if cancel.is_set():
            raise QueryCancelled
        rows.append(row)
        if len(rows) > limit:
            break
    return rows


class OxigraphBackend:
    """pyoxigraph, in memory."""

    name = "oxigraph"

    def __init__(self, scenes: Iterable[tuple[str, str]]) -> None:
        """``scenes``: (graph IRI, N-Triples text) of each scene."""
        import pyoxigraph as ox

        self._ox = ox
        self._named, self._literal, self._blank = ox.NamedNode, ox.Literal, ox.BlankNode
        self.store = ox.Store()
        for graph, ntriples in scenes:
            if ntriples:
                # lenient: the text comes from our own writer, whose IRIs are percent-encoded
                self.store.bulk_load(ntriples.encode("utf-8"), ox.RdfFormat.N_TRIPLES,
                                     to_graph=ox.NamedNode(graph), lenient=True)  # fmt: skip

    def __len__(self) -> int:
        return len(self.store)

    def _term(self, term: URIRef | Literal) -> Any:
        ox = self._ox
        if isinstance(term, URIRef):
            return ox.NamedNode(str(term))
        if term.language:
            return ox.Literal(str(term), language=term.language)
        datatype = ox.NamedNode(str(term.datatype)) if term.datatype is not None else None
        return ox.Literal(str(term), datatype=datatype)

    def _result_term(self, term: Any) -> Term | None:
        kind = type(term)
        if kind is self._named:
            return str(term.value)
        if kind is self._literal:
            datatype = term.datatype.value
            return Lit(term.value, datatype, term.language if datatype == RDF_LANG_STRING else None)
        if term is None:
            return None
        if kind is self._blank:
            return "_:" + str(term.value)
        return str(term)

    def run(
        self,
        query: CheckedQuery,
        bindings: Mapping[str, URIRef | Literal],
        limit: int,
        cancel: threading.Event,
        selection: Selection = None,
    ) -> RawResult:
        try:
            return self._run(query, bindings, limit, cancel, selection)
        except SyntaxError as exc:
            raise SparqlSyntaxError(f"SPARQL syntax error: {exc}") from exc
        except (OSError, ValueError, RuntimeError, TypeError) as exc:
            raise SparqlError(f"SPARQL evaluation failed: {type(exc).__name__}: {exc}") from exc

    def _run(
        self,
        query: CheckedQuery,
        bindings: Mapping[str, URIRef | Literal],
        limit: int,
        cancel: threading.Event,
        selection: Selection,
    ) -> RawResult:
        ox, value = self._ox, self._result_term
        text = inject_values(query.text, bindings) if bindings else query.text
        subs = None
        if text is None:  # no WHERE pattern to put a VALUES block in
            text = query.text
            subs = {ox.Variable(k): self._term(v) for k, v in bindings.items()}
        dataset: dict[str, Any] = {}
        if selection is not None:
            default, named = selection
            dataset = {"default_graph": [ox.NamedNode(g) for g in default],
                       "named_graphs": [ox.NamedNode(g) for g in named]}  # fmt: skip
        elif not query.dataset:
            dataset = {"use_default_graph_as_union": True}
        result: Any = self.store.query(text, prefixes=dict(PREFIXES), substitutions=subs, **dataset)
        if query.kind == "ask":
            return RawResult("ask", (), [], bool(result))
        if query.kind == "graph":
            triples = ((value(t.subject), value(t.predicate), value(t.object)) for t in result)
            return RawResult("graph", GRAPH_COLUMNS, _take(triples, limit, cancel), None)
        names = [v.value for v in result.variables]
        rows: Iterator[tuple[Term | None, ...]] = (tuple(value(t) for t in sol) for sol in result)
        if query.select_all:
            order = sorted(range(len(names)), key=names.__getitem__)
            names = [names[i] for i in order]
            rows = (tuple(r[i] for i in order) for r in rows)
        return RawResult("select", tuple(names), _take(rows, limit, cancel), None)


_cancel_flags = threading.local()


class _CancellableMemory(Memory):
    """rdflib's memory store; every lookup first checks its thread's cancel flag."""

    def triples(self, triple_pattern: Any, context: Any = None) -> Generator[Any, None, None]:
        flag = getattr(_cancel_flags, "event", None)
        if flag is not None and flag.is_set():
            raise QueryCancelled
        yield from super().triples(triple_pattern, context)


_load_graphs_lock = threading.Lock()
_load_graphs_users = 0
_load_graphs_saved = True


@contextmanager
def _no_remote_graphs() -> Iterator[None]:
    """Turn rdflib's loading of graphs named in a query off while any evaluation runs."""
    global _load_graphs_users, _load_graphs_saved
    import rdflib.plugins.sparql as rdflib_sparql

    with _load_graphs_lock:
        if _load_graphs_users == 0:
            _load_graphs_saved = rdflib_sparql.SPARQL_LOAD_GRAPHS
            rdflib_sparql.SPARQL_LOAD_GRAPHS = False
        _load_graphs_users += 1
    try:
        yield
    finally:
        with _load_graphs_lock:
            _load_graphs_users -= 1
            if _load_graphs_users == 0:
                rdflib_sparql.SPARQL_LOAD_GRAPHS = _load_graphs_saved


class RdflibBackend:
    """rdflib, in memory."""

    name = "rdflib"

    def __init__(self, graphs: list[SceneGraph], *, evidence: bool) -> None:
        from graph_store.rdf._rdflib_graph import to_rdflib_dataset

        self.graph = to_rdflib_dataset(graphs, evidence=evidence, store=_CancellableMemory())

    def __len__(self) -> int:
        return len(self.graph)

    @staticmethod
    def _result_term(term: Any) -> Term | None:
        if term is None:
            return None
        if isinstance(term, URIRef):
            return str(term)
        if isinstance(term, BNode):
            return "_:" + str(term)
        if isinstance(term, Literal):
            if term.language:
                return Lit(str(term), RDF_LANG_STRING, term.language)
            datatype = _XSD_STRING if term.datatype is None else str(term.datatype)
            return Lit(str(term), datatype)
        return str(term)

    def run(
        self,
        query: CheckedQuery,
        bindings: Mapping[str, URIRef | Literal],
        limit: int,
        cancel: threading.Event,
        selection: Selection = None,
    ) -> RawResult:
        if selection is not None:
            raise SparqlArgumentError(
                "a dataset given beside the query (default-graph-uri, named-graph-uri) needs"
                " the oxigraph engine; on rdflib, name it in the query (FROM, FROM NAMED)"
            )
        value = self._result_term
        _cancel_flags.event = cancel
        try:
            with _no_remote_graphs():
                result: Any = self.graph.query(query.prepared, initBindings=dict(bindings))
                if query.kind == "ask":
                    return RawResult("ask", (), [], bool(result.askAnswer))
                if query.kind == "graph":
                    triples = ((value(s), value(p), value(o)) for s, p, o in result)
                    return RawResult("graph", GRAPH_COLUMNS, _take(triples, limit, cancel), None)
                names = [str(v) for v in (result.vars or [])]
                if query.select_all:
                    names.sort()
                variables = [Variable(n) for n in names]
                rows = (tuple(value(row.get(v)) for v in variables) for row in result)
                return RawResult("select", tuple(names), _take(rows, limit, cancel), None)
        except (QueryCancelled, SparqlError):
            raise
        except Exception as exc:  # rdflib raises assorted exception types while evaluating
            raise SparqlError(f"SPARQL evaluation failed: {type(exc).__name__}: {exc}") from exc
        finally:
            _cancel_flags.event = None
