"""Read-only SPARQL over the RDF view of one or more scene graphs.

>>> view = RdfView.from_graphs(graph)                                    # doctest: +SKIP
>>> view.query("SELECT ?a ?b WHERE { ?a csg:above ?b }").rows            # doctest: +SKIP

* The standard prefixes (``csg``, ``bot``, ``geo``, ``rdf``, ``rdfs``, ``xsd``, ``owl``) are
  predeclared; ``PREFIX`` lines in the query take precedence.
* Only queries run (SELECT, ASK, CONSTRUCT, DESCRIBE). Updates, ``SERVICE`` and
  ``FROM``/``FROM NAMED`` are refused with :class:`SparqlForbiddenError` before anything is
  evaluated, on both engines, so a query never opens a network connection.
* User values go in through ``bindings`` (typed RDF terms), never into the query text.
* ``limit`` bounds the rows consumed; ``timeout_s`` bounds the evaluation. On Linux the
  query is evaluated in a forked worker process (it shares the view's memory copy-on-write,
  so nothing is serialised but the rows) under an address-space limit of ``memory_mb``
  above what the process already maps (default: half the machine's memory); on timeout the
  worker is killed, so its time and memory are given back at once, and the caller gets
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
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
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
from graph_store.rdf._parse import have_pyoxigraph
from graph_store.rdf._sparql_backends import (
    OxigraphBackend,
    QueryCancelled,
    RawResult,
    RdflibBackend,
)
from graph_store.rdf._sparql_guard import CheckedQuery, QueryKind, check_query, query_variables
from graph_store.rdf._sparql_text import render_term
from graph_store.types import SceneGraph

BackendName = Literal["auto", "oxigraph", "rdflib"]
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
    """

    kind: QueryKind
    columns: tuple[str, ...]
    rows: tuple[tuple[object, ...], ...]
    boolean: bool | None = None
    truncated: bool = False

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
    ) -> RawResult: ...


class RdfView:
    """An immutable, queryable RDF view of scene graphs (built once, queried many times)."""

    def __init__(self, backend: _Backend, scene_ids: tuple[str, ...]) -> None:
        self._backend = backend
        self.scene_ids = scene_ids

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
            text = "".join(iter_chunks(items, turtle=False, evidence=evidence))
            return cls(OxigraphBackend(text), ids)
        if backend == "rdflib":
            return cls(RdflibBackend(items, evidence=evidence), ids)
        raise ValueError(f"unknown SPARQL backend {backend!r}; expected oxigraph, rdflib or auto")

    @property
    def backend(self) -> str:
        """``"oxigraph"`` or ``"rdflib"``."""
        return self._backend.name

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
    ) -> SparqlResult:
        """Run one read-only SPARQL query.

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
            raw = self._run_in_worker(checked, terms, limit, timeout_s, memory_mb)
        else:
            raw = self._run_with_timeout(checked, terms, limit, timeout_s)
        truncated = len(raw.rows) > limit
        if truncated and on_limit == "error":
            raise SparqlRowLimitError(f"the query gives more than {limit} rows (limit={limit})")
        return SparqlResult(
            kind=raw.kind,
            columns=raw.columns,
            rows=tuple(raw.rows[:limit]),
            boolean=raw.boolean,
            truncated=truncated,
        )

    def _run_with_timeout(
        self,
        checked: CheckedQuery,
        terms: Mapping[str, URIRef | RdfLiteral],
        limit: int,
        timeout_s: float,
    ) -> RawResult:
        cancel = threading.Event()
        outcome: list[RawResult | BaseException] = []

        def work() -> None:
            try:
                outcome.append(self._backend.run(checked, terms, limit, cancel))
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

    def _run_in_worker(
        self,
        checked: CheckedQuery,
        terms: Mapping[str, URIRef | RdfLiteral],
        limit: int,
        timeout_s: float,
        memory_mb: int | None,
    ) -> RawResult:
        import multiprocessing

        context = multiprocessing.get_context("fork")
        receive, send = context.Pipe(duplex=False)
        budget = (memory_mb << 20) if memory_mb is not None else _default_memory_bytes()
        worker = context.Process(
            target=_worker_main,
            args=(self._backend, checked, terms, limit, budget, send),
            name="sparql-query",
            daemon=True,
        )
        worker.start()
        send.close()
        try:
            if not receive.poll(timeout_s):
                raise SparqlTimeoutError(f"the SPARQL query did not finish within {timeout_s} s")
            try:
                status, payload = receive.recv()
            except EOFError:
                status, payload = "died", None
        finally:
            if worker.is_alive():
                worker.kill()
            worker.join()
            receive.close()
        if status == "ok":
            return payload
        if status == "error":
            raise payload
        limit_mb = _worker_cap(budget) >> 20
        raise SparqlResourceError(
            f"the SPARQL query ran out of memory (its worker may grow {limit_mb} MB; narrow"
            " the query, or raise memory_mb or the process's address-space limit)"
            if status == "memory" or worker.exitcode in (-6, -9, 134, 137)
            else f"the SPARQL query's worker ended without an answer (exit {worker.exitcode})"
        )


def can_isolate() -> bool:
    """Whether queries can run in a forked worker process (Linux)."""
    import multiprocessing

    return sys.platform.startswith("linux") and "fork" in multiprocessing.get_all_start_methods()


def _default_memory_bytes() -> int:
    """Half the machine's physical memory."""
    import os

    return int(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")) // 2


def _mapped_bytes() -> int:
    """The address space this process maps now (``/proc/self/statm``; 0 where absent)."""
    import resource

    try:
        with open("/proc/self/statm") as statm:
            return int(statm.read().split()[0]) * resource.getpagesize()
    except (OSError, ValueError, IndexError):
        return 0


def _worker_cap(budget: int) -> int:
    """How far a worker forked now may grow: ``budget``, or less under an inherited limit."""
    import resource

    soft, _hard = resource.getrlimit(resource.RLIMIT_AS)
    if soft == resource.RLIM_INFINITY:
        return budget
    return max(0, min(budget, soft - _mapped_bytes()))


def _worker_main(
    backend: _Backend,
    checked: CheckedQuery,
    terms: Mapping[str, URIRef | RdfLiteral],
    limit: int,
    budget: int,
    send: Any,
) -> None:  # pragma: no cover - runs in the forked worker (its outcomes are tested)
    import os
    import resource

    try:  # an engine that aborts on a failed allocation prints there: keep it off the
        null = os.open(os.devnull, os.O_WRONLY)  # caller's terminal (errors come by pipe)
        os.dup2(null, 2)
        mapped = _mapped_bytes()
        if mapped:
            _soft, hard = resource.getrlimit(resource.RLIMIT_AS)
            resource.setrlimit(resource.RLIMIT_AS, (mapped + _worker_cap(budget), hard))
    except (OSError, ValueError):
        pass  # no /proc or no permission: the inherited limits hold
    try:
        message: tuple[str, Any] = ("ok", backend.run(checked, terms, limit, threading.Event()))
    except MemoryError:
        message = ("memory", None)
    except Exception as exc:  # handed to the caller, as the thread path does
        message = ("error", exc)
    try:
        send.send(message)
    except MemoryError:
        send.send(("memory", None))
    send.close()


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
