"""Where the SPARQL executor sends its queries: pyoxigraph, rdflib, or an ``RdfView``.

Every endpoint answers ``select(text)`` with rows of Python values (IRIs as ``str``,
``xsd:integer`` as ``int``, ``xsd:double`` as ``float``, strings as ``str``) and
``ask(text)`` with a bool. The executor's own queries are generated, read-only text, so
the direct endpoints (:class:`OxigraphEndpoint`, :class:`RdflibEndpoint`) hand them to the
engine as they are; :class:`RdfViewEndpoint` goes through
:meth:`graph_store.rdf.RdfView.query` and its admission check (which parses every query
with rdflib, and so costs milliseconds per query).
"""

from __future__ import annotations

from typing import Any, Literal, Protocol

from graph_store.rdf.namespace import PREFIXES
from graph_store.types import SceneGraph
from queries.errors import QueryExecutionError

_XSD = PREFIXES["xsd"]
_INTEGERS = frozenset(
    _XSD + t
    for t in (
        "integer", "int", "long", "short", "byte", "nonNegativeInteger", "positiveInteger",
        "nonPositiveInteger", "negativeInteger", "unsignedLong", "unsignedInt",
        "unsignedShort", "unsignedByte",
    )
)  # fmt: skip
_FLOATS = frozenset({_XSD + "double", _XSD + "float", _XSD + "decimal"})
#: Row limit passed to an RdfView (the executor's own queries are never truncated).
_NO_LIMIT = 1 << 62

SparqlBackendName = Literal["oxigraph", "rdflib"]


class SparqlEndpoint(Protocol):
    """What the SPARQL executor needs from an engine."""

    name: str

    def select(self, text: str) -> list[tuple[Any, ...]]: ...

    def iris(self, text: str) -> list[str]:
        """The first projected variable of every solution, which must be an IRI."""
        ...

    def ask(self, text: str) -> bool: ...


def _literal(lexical: str, datatype: str) -> Any:
    if datatype in _INTEGERS:
        return int(lexical)
    if datatype in _FLOATS:
        return float(lexical)
    return lexical


class OxigraphEndpoint:
    """An in-memory pyoxigraph store."""

    name = "oxigraph"

    def __init__(self, store: Any) -> None:
        import pyoxigraph as ox

        self._ox = ox
        self.store = store

    @classmethod
    def from_graphs(cls, graphs: list[SceneGraph]) -> OxigraphEndpoint:
        import pyoxigraph as ox

        from graph_store.rdf import serialize_scenes

        store = ox.Store()
        text = serialize_scenes(graphs, "ntriples", evidence=False)
        if text:
            store.bulk_load(text.encode("utf-8"), ox.RdfFormat.N_TRIPLES)
        return cls(store)

    def _value(self, term: Any) -> Any:
        ox = self._ox
        if term is None:
            return None
        if isinstance(term, ox.Literal):
            return _literal(term.value, term.datatype.value)
        return term.value

    def select(self, text: str) -> list[tuple[Any, ...]]:
        try:
            solutions = self.store.query(text)
            return [tuple(self._value(t) for t in row) for row in solutions]
        except (SyntaxError, OSError, ValueError, RuntimeError) as exc:
            raise QueryExecutionError(f"oxigraph could not run a query: {exc}") from exc

    def iris(self, text: str) -> list[str]:
        # Serialising in Rust and splitting the text is several times faster than
        # building a Python object per solution.
        try:
            data = self.store.query(text).serialize(format=self._ox.QueryResultsFormat.TSV)
        except (SyntaxError, OSError, ValueError, RuntimeError) as exc:
            raise QueryExecutionError(f"oxigraph could not run a query: {exc}") from exc
        lines = data.decode("utf-8").split("\n")[1:]
        out = []
        for line in lines:
            if line:
                first = line.split("\t", 1)[0]
                if not (first.startswith("<") and first.endswith(">")):
                    raise QueryExecutionError(f"expected an IRI in a query result, got {first!r}")
                out.append(first[1:-1])
        return out

    def ask(self, text: str) -> bool:
        try:
            return bool(self.store.query(text))
        except (SyntaxError, OSError, ValueError, RuntimeError) as exc:
            raise QueryExecutionError(f"oxigraph could not run a query: {exc}") from exc


class RdflibEndpoint:
    """An rdflib ``Graph`` (in memory by default)."""

    name = "rdflib"

    def __init__(self, graph: Any) -> None:
        self.graph = graph

    @classmethod
    def from_graphs(cls, graphs: list[SceneGraph]) -> RdflibEndpoint:
        from graph_store.rdf import to_rdflib_graph

        return cls(to_rdflib_graph(graphs, evidence=False))

    @staticmethod
    def _value(term: Any) -> Any:
        from rdflib import Literal

        if term is None:
            return None
        if isinstance(term, Literal):
            datatype = str(term.datatype) if term.datatype is not None else _XSD + "string"
            return _literal(str(term), datatype)
        return str(term)

    def select(self, text: str) -> list[tuple[Any, ...]]:
        result = self.graph.query(text)
        return [tuple(self._value(t) for t in row) for row in result]

    def iris(self, text: str) -> list[str]:
        return [str(row[0]) for row in self.graph.query(text)]

    def ask(self, text: str) -> bool:
        return bool(self.graph.query(text).askAnswer)


class RdfViewEndpoint:
    """A :class:`graph_store.rdf.RdfView` (read-only, admission-checked queries)."""

    def __init__(self, view: Any, *, timeout_s: float = 60.0) -> None:
        self.view = view
        self.timeout_s = timeout_s
        self.name = f"rdfview-{view.backend}"

    def select(self, text: str) -> list[tuple[Any, ...]]:
        result = self.view.query(text, limit=_NO_LIMIT, timeout_s=self.timeout_s)
        return [tuple(row) for row in result.rows]

    def iris(self, text: str) -> list[str]:
        return [str(row[0]) for row in self.select(text)]

    def ask(self, text: str) -> bool:
        return bool(self.view.query(text, timeout_s=self.timeout_s).boolean)


def endpoint_for(graphs: list[SceneGraph], backend: SparqlBackendName) -> SparqlEndpoint:
    """A direct endpoint over the RDF view of ``graphs`` (``"oxigraph"`` or ``"rdflib"``)."""
    if backend == "oxigraph":
        return OxigraphEndpoint.from_graphs(graphs)
    if backend == "rdflib":
        return RdflibEndpoint.from_graphs(graphs)
    raise QueryExecutionError(f"unknown SPARQL backend {backend!r}; expected oxigraph or rdflib")
