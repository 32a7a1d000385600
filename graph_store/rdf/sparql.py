"""Read-only SPARQL over the RDF view of one or more scene graphs.

>>> view = RdfView.from_graphs(graph)                                    # doctest: +SKIP
>>> view.query("SELECT ?a ?b WHERE { ?a csg:above ?b }").rows            # doctest: +SKIP

* The standard prefixes (``csg``, ``bot``, ``geo``, ``rdf``, ``rdfs``, ``xsd``, ``owl``) are
  predeclared; ``PREFIX`` lines in the query take precedence.
* Only queries run (SELECT, ASK, CONSTRUCT, DESCRIBE). Updates and ``SERVICE`` are
  refused with :class:`SparqlForbiddenError` before anything is evaluated, on both engines,
  so a query never opens a network connection.
* Each scene is a named graph (its scene IRI), the default graph their union; ``FROM`` /
  ``FROM NAMED`` select among them and load nothing (:meth:`RdfView.query`).
* User values go in through ``bindings`` (typed RDF terms), never into the query text.
* ``limit`` bounds the rows consumed; ``timeout_s`` bounds the evaluation. On Linux the
  query is evaluated in a forked worker process (it shares the view's memory copy-on-write,
  so nothing is serialised but the query and the rows; a view forks up to :data:`WORKERS`
  of them, reused, one query each, so a long query does not hold up the next) under
  an address-space limit of ``memory_mb`` above what the process maps (default: half the
  machine's memory); on timeout the worker is killed (the next query forks a new one), so
  its time and memory are given back at once, and the caller gets
  :class:`SparqlTimeoutError`; a worker that runs out of its memory gets
  :class:`SparqlResourceError` (a subclass). Elsewhere, or with ``isolate=False``, the query
  runs in a daemon thread that is told to stop on timeout: it stops at its next result
  (oxigraph) or its next triple lookup (rdflib), but an oxigraph evaluation still
  computing its first result (a large sort or aggregate) runs on in the background.
"""

from __future__ import annotations

import math
import numbers
import re
import sys
import threading
import time
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal, Protocol

from rdflib import XSD, URIRef
from rdflib import Literal as RdfLiteral

from graph_store.errors import (
    SparqlArgumentError,
    SparqlError,
    SparqlResourceError,
    SparqlRowLimitError,
    SparqlTimeoutError,
)
from graph_store.rdf._parse import Term, have_pyoxigraph
from graph_store.rdf._sparql_backends import (
    OxigraphBackend,
    QueryCancelled,
    RawResult,
    RdflibBackend,
    Selection,
    term_value,
)
from graph_store.rdf._sparql_guard import CheckedQuery, QueryKind, check_query, query_variables
from graph_store.rdf._sparql_text import render_term
from graph_store.rdf._sparql_worker import QueryWorker, can_isolate, default_budget
from graph_store.rdf.iris import scene_iri
from graph_store.types import SceneGraph

BackendName = Literal["auto", "oxigraph", "rdflib"]
ResultFormat = Literal[
    "json", "xml", "csv", "tsv", "turtle", "ntriples", "jsonld", "rdfxml", "nquads", "trig", "n3"
]
#: Worker processes a view forks at most, one query each: a long query does not hold up
#: the others (each is stopped at its own timeout); more wait for one to come free.
WORKERS = 2
_ABSOLUTE_IRI_RE = re.compile(r"[A-Za-z][A-Za-z0-9+.-]*:[^\s<>\"{}|\\^`]*\Z")
_VARNAME_RE = re.compile(r"[^\W][\w\u00b7\u0300-\u036f\u203f\u2040]*\Z")


@dataclass(frozen=True, slots=True)
class SparqlResult:
    """The answer to one SPARQL query, as plain Python values.

    Attributes:
        kind: ``"select"``, ``"ask"`` or ``"graph"`` (CONSTRUCT / DESCRIBE).
        columns: variable names for SELECT (sorted by name for ``SELECT *``);
            ``("subject", "predicate", "object")`` for graph results; ``()`` for ASK.
        rows: one tuple per solution or triple. IRIs are ``str``, blank nodes ``"_:label"``,
            literals their Python value (``int``, ``float``, ``bool``, ``str``; the lexical
            form for other datatypes), unbound variables ``None``.
        boolean: the answer of an ASK query, else ``None``.
        truncated: ``True`` when more than ``limit`` rows were available and only the
            first ``limit`` are returned.
        terms: the same rows as RDF terms, which :meth:`serialize` writes: an IRI as
            ``str``, a blank node as ``"_:label"``, a literal as a ``Lit(lexical,
            datatype, lang)`` named tuple, unbound ``None``. Not compared: two results
            are equal when their Python values are.
    """

    kind: QueryKind
    columns: tuple[str, ...]
    rows: tuple[tuple[object, ...], ...]
    boolean: bool | None = None
    truncated: bool = False
    terms: tuple[tuple[Term | None, ...], ...] = field(default=(), compare=False, repr=False)

    def serialize(self, format: ResultFormat | None = None) -> str:
        """The result as a W3C document: for SELECT and ASK the SPARQL 1.1 Query Results
        ``"json"`` (the default), ``"xml"``, ``"csv"`` or ``"tsv"`` (not ASK); for
        CONSTRUCT / DESCRIBE the RDF graph as ``"turtle"`` (the default), ``"ntriples"``,
        ``"jsonld"`` or ``"rdfxml"``. A truncated result holds its first ``limit`` rows.

        Raises :class:`~graph_store.errors.SparqlFormatError` for a format of the other
        kind of result, and for text that XML cannot hold.
        """
        from graph_store.rdf.results import serialize_result

        return serialize_result(self, format)

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready dict of the fields (rows as lists)."""
        return {
            "kind": self.kind,
            "columns": list(self.columns),
            "rows": [list(row) for row in self.rows],
            "boolean": self.boolean,
            "truncated": self.truncated,
        }


class _Backend(Protocol):
    name: str

    def __len__(self) -> int: ...

    def run(
        self,
        query: CheckedQuery,
        bindings: Mapping[str, URIRef | RdfLiteral],
        limit: int,
        cancel: threading.Event,
        selection: Selection = None,
    ) -> RawResult: ...


class RdfView:
    """An immutable, queryable RDF view of scene graphs (built once, queried many times)."""

    def __init__(
        self, backend: _Backend, scene_ids: tuple[str, ...], *, workers: int = WORKERS
    ) -> None:
        if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
            raise SparqlArgumentError(f"workers must be an integer >= 1, got {workers!r}")
        self._backend = backend
        self.scene_ids = scene_ids
        self.workers = workers
        self._idle: list[QueryWorker] = []  # forked workers free for a query
        self._busy = 0
        self._pool = threading.Condition()

    @classmethod
    def from_graphs(
        cls,
        graphs: SceneGraph | Iterable[SceneGraph],
        *,
        backend: BackendName = "auto",
        evidence: bool = True,
    ) -> RdfView:
        """Build the view. ``backend``: ``"oxigraph"`` (pyoxigraph, fast), ``"rdflib"``, or
        ``"auto"`` (pyoxigraph when installed, else rdflib). ``evidence``: include the
        relation assertion nodes (see :func:`~graph_store.rdf.serialize_scenes`)."""
        from graph_store.rdf.export import as_scene_list, iter_chunks

        items = as_scene_list(graphs)
        ids = tuple(g.scene_id for g in items)
        if backend == "auto":
            backend = "oxigraph" if have_pyoxigraph() else "rdflib"
        if backend == "oxigraph":
            if not have_pyoxigraph():
                raise ImportError(
                    "the oxigraph SPARQL backend needs pyoxigraph: pip install pyoxigraph"
                    " (or use backend='rdflib')"
                )
            scenes = (
                (scene_iri(g.scene_id), "".join(iter_chunks([g], turtle=False, evidence=evidence)))
                for g in items
            )
            return cls(OxigraphBackend(scenes), ids)
        if backend == "rdflib":
            return cls(RdflibBackend(items, evidence=evidence), ids)
        raise ValueError(f"unknown SPARQL backend {backend!r}; expected oxigraph, rdflib or auto")

    @property
    def backend(self) -> str:
        """``"oxigraph"`` or ``"rdflib"``."""
        return self._backend.name

    def close(self) -> None:
        """End this view's idle worker processes (a later query forks anew; one running a
        query ends when its query does)."""
        with self._pool:
            idle, self._idle = self._idle, []
        for worker in idle:
            worker.close()

    def _take_worker(self, budget: int, timeout_s: float) -> QueryWorker:
        """A worker free for one query: an idle one, a new one while fewer than
        :attr:`workers` run, or the first to come free within ``timeout_s``."""
        deadline = time.monotonic() + timeout_s
        with self._pool:
            while not self._idle and self._busy >= self.workers:
                left = deadline - time.monotonic()
                if left <= 0 or not self._pool.wait(left):
                    raise SparqlTimeoutError(
                        f"the SPARQL query did not finish within {timeout_s} s: all"
                        f" {self.workers} workers of this view stayed busy"
                    )
            self._busy += 1
            worker = self._idle.pop() if self._idle else None
        if worker is None or worker.budget != budget:
            if worker is not None:
                worker.close()
            worker = QueryWorker(self._backend, budget)
        return worker

    def _give_back(self, worker: QueryWorker) -> None:
        with self._pool:
            self._busy -= 1
            self._idle.append(worker)
            self._pool.notify()

    @property
    def busy(self) -> int:
        """The number of this view's workers running a query now."""
        with self._pool:
            return self._busy

    def __len__(self) -> int:
        """The number of triples in the view."""
        return len(self._backend)

    def query(
        self,
        text: str,
        *,
        bindings: Mapping[str, Any] | None = None,
        limit: int = 10_000,
        timeout_s: float = 30.0,
        on_limit: Literal["truncate", "error"] = "truncate",
        memory_mb: int | None = None,
        isolate: bool | None = None,
        default_graphs: Sequence[str] | None = None,
        named_graphs: Sequence[str] | None = None,
    ) -> SparqlResult:
        """Run one read-only SPARQL query.

        The dataset: each scene's triples in the named graph of its IRI
        (:func:`~graph_store.rdf.iris.scene_iri`, so ``GRAPH ?g`` ranges over scenes), their
        union as the default graph; a query's ``FROM`` / ``FROM NAMED`` choose among those
        graphs (nothing is loaded). ``default_graphs`` / ``named_graphs`` (graph IRIs, the
        protocol's ``default-graph-uri`` / ``named-graph-uri``; oxigraph only) replace the
        query's dataset: the default graph is the merge of ``default_graphs`` (empty when
        only ``named_graphs`` is given) and ``GRAPH`` sees ``named_graphs`` only.

        ``bindings``: variable name (with or without ``?``) to value: ``str`` binds a plain
        literal, ``int``/``float``/``bool`` (and numpy scalars) typed literals, ``rdflib.URIRef`` or
        ``pyoxigraph.NamedNode`` an IRI, ``rdflib.Literal`` / ``pyoxigraph.Literal`` as given.
        ``limit``: the most rows returned; beyond it the result is truncated
        (``on_limit="truncate"``) or :class:`SparqlRowLimitError` is raised (``"error"``).
        ``timeout_s``: raise :class:`SparqlTimeoutError` when no answer came in time.
        ``memory_mb``: the worker's memory limit above what this process maps (default:
        half the machine's memory). ``isolate``: run in a worker process (default: where
        ``fork`` is available, Linux) or, with ``False``, in a thread (module docstring).
        """
        if isinstance(limit, bool) or not isinstance(limit, int) or limit < 0:
            raise SparqlArgumentError(f"limit must be an integer >= 0, got {limit!r}")
        if not (isinstance(timeout_s, int | float) and timeout_s > 0 and math.isfinite(timeout_s)):
            raise SparqlArgumentError(
                f"timeout_s must be a finite number of seconds > 0, got {timeout_s!r}"
            )
        if on_limit not in ("truncate", "error"):
            raise SparqlArgumentError(f"on_limit must be 'truncate' or 'error', got {on_limit!r}")
        if memory_mb is not None and (
            isinstance(memory_mb, bool) or not isinstance(memory_mb, int) or memory_mb < 16
        ):
            raise SparqlArgumentError(f"memory_mb must be an integer >= 16, got {memory_mb!r}")
        checked = check_query(text)
        selection = _selection(default_graphs, named_graphs)
        terms = {_var_name(k): to_rdf_term(k, v) for k, v in (bindings or {}).items()}
        names = query_variables(checked)
        unused = sorted(set(terms) - names)
        if unused:
            have = ", ".join("?" + v for v in sorted(names) if not v.startswith("__")) or "none"
            raise SparqlArgumentError(
                f"binding {', '.join('?' + n for n in unused)}: the query has no such"
                f" variable (it has {have})"
            )
        if isolate is None:
            isolate = can_isolate()
        if isolate:
            budget = default_budget() if memory_mb is None else memory_mb << 20
            started = time.monotonic()
            worker = self._take_worker(budget, timeout_s)
            try:
                left = max(0.001, timeout_s - (time.monotonic() - started))
                raw = worker.run(checked.text, terms, limit, left, selection)
            except SparqlResourceError:
                raise
            except SparqlTimeoutError:
                raise SparqlTimeoutError(
                    f"the SPARQL query did not finish within {timeout_s} s"
                ) from None
            finally:
                self._give_back(worker)
        else:
            raw = self._run_with_timeout(checked, terms, limit, timeout_s, selection)
        truncated = len(raw.rows) > limit
        if truncated and on_limit == "error":
            raise SparqlRowLimitError(f"the query gives more than {limit} rows (limit={limit})")
        kept = tuple(raw.rows[:limit])
        return SparqlResult(
            kind=raw.kind,
            columns=raw.columns,
            rows=tuple(tuple(term_value(t) for t in row) for row in kept),
            boolean=raw.boolean,
            truncated=truncated,
            terms=kept,
        )

    def _run_with_timeout(
        self,
        checked: CheckedQuery,
        terms: Mapping[str, URIRef | RdfLiteral],
        limit: int,
        timeout_s: float,
        selection: Selection = None,
    ) -> RawResult:
        cancel = threading.Event()
        outcome: list[RawResult | BaseException] = []

        def work() -> None:
            try:
                outcome.append(self._backend.run(checked, terms, limit, cancel, selection))
            except QueryCancelled:
                pass
            except BaseException as exc:  # handed to the caller's thread
                outcome.append(exc)

        worker = threading.Thread(target=work, name="sparql-query", daemon=True)
        worker.start()
        worker.join(timeout_s)
        if worker.is_alive():
            cancel.set()
            raise SparqlTimeoutError(f"the SPARQL query did not finish within {timeout_s} s")
        if not outcome:
            raise SparqlError("the SPARQL query was cancelled")
        result = outcome[0]
        if isinstance(result, BaseException):
            raise result
        return result


def query_kind(text: str) -> QueryKind:
    """What ``text`` asks for: ``"select"``, ``"ask"`` or ``"graph"`` (CONSTRUCT, DESCRIBE).

    Admits the text as :meth:`RdfView.query` does, so it raises the same errors for
    updates, ``SERVICE`` and syntax errors, before any view is built.

    >>> query_kind("CONSTRUCT { ?s ?p ?o } WHERE { ?s ?p ?o }")
    'graph'
    """
    return check_query(text).kind


def _selection(
    default_graphs: Sequence[str] | None, named_graphs: Sequence[str] | None
) -> Selection:
    """The dataset given beside a query, its IRIs checked; ``None`` when neither names a
    graph (both ``None`` or empty)."""
    if not default_graphs and not named_graphs:
        return None
    out = []
    for name, iris_ in (("default graph", default_graphs), ("named graph", named_graphs)):
        if isinstance(iris_, str):
            raise SparqlArgumentError(f"{name}s are a list of graph IRIs, not one string")
        items = tuple(iris_ or ())
        for iri in items:
            if not isinstance(iri, str) or not _ABSOLUTE_IRI_RE.match(iri):
                raise SparqlArgumentError(f"{name}: {iri!r} is not an absolute IRI")
        out.append(items)
    return (out[0], out[1])


def _var_name(name: object) -> str:
    if not isinstance(name, str):
        raise SparqlError(f"binding names must be strings, got {name!r}")
    bare = name[1:] if name[:1] in ("?", "$") else name
    if not _VARNAME_RE.match(bare):
        raise SparqlError(f"binding name {name!r} is not a SPARQL variable name")
    return bare


def to_rdf_term(name: str, value: Any) -> URIRef | RdfLiteral:
    """The RDF term a binding value stands for (see :meth:`RdfView.query`).

    Raises :class:`SparqlError` for values of other types and for IRIs, datatypes or
    language tags that are not valid in SPARQL.
    """
    term = _to_term(name, value)
    try:
        render_term(term)
    except SparqlError as exc:
        raise SparqlError(f"binding {name!r}: {exc}") from None
    return term


def _to_term(name: str, value: Any) -> URIRef | RdfLiteral:
    if isinstance(value, URIRef):
        return value
    if isinstance(value, RdfLiteral):
        return _plain_if_string(value)
    bool_types = (bool, *numpy_bool_types())
    if isinstance(value, bool_types):
        return RdfLiteral("true" if value else "false", datatype=XSD.boolean)
    if isinstance(value, numbers.Integral):
        return RdfLiteral(str(int(value)), datatype=XSD.integer)
    if isinstance(value, numbers.Real):
        return RdfLiteral(repr(float(value)), datatype=XSD.double)
    if isinstance(value, str):
        return RdfLiteral(value)
    converted = _from_pyoxigraph(value)
    if converted is not None:
        return converted
    raise SparqlError(
        f"binding {name!r}: cannot bind a {type(value).__name__} ({value!r}); use str, int,"
        " float, bool, rdflib.URIRef/Literal or pyoxigraph.NamedNode/Literal"
    )


def numpy_bool_types() -> tuple[type, ...]:
    """``numpy.bool_`` when numpy is loaded (it is not a ``bool`` subclass)."""
    numpy = sys.modules.get("numpy")
    return (numpy.bool_,) if numpy is not None else ()


def _from_pyoxigraph(value: Any) -> URIRef | RdfLiteral | None:
    if not have_pyoxigraph():
        return None
    import pyoxigraph as ox

    if isinstance(value, ox.NamedNode):
        return URIRef(value.value)
    if isinstance(value, ox.Literal):
        if value.language:
            return RdfLiteral(value.value, lang=value.language)
        return _plain_if_string(RdfLiteral(value.value, datatype=URIRef(value.datatype.value)))
    return None


def _plain_if_string(value: RdfLiteral) -> RdfLiteral:
    """``"x"^^xsd:string`` as the simple literal ``"x"`` (the same term in RDF 1.1)."""
    if value.datatype == XSD.string:
        return RdfLiteral(str(value))
    return value
