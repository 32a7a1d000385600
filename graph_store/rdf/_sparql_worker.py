"""A forked worker process that answers one RDF view's SPARQL queries, killed on timeout.

An evaluation in a thread cannot be stopped from outside: pyoxigraph computing its first
result (a large sort or aggregate) runs on after its caller gave up, and keeps its memory.
A process can be killed. :class:`QueryWorker` forks once per view (the view's store is
shared copy-on-write, nothing is serialised but the query text and the rows), answers
queries over a pipe, and is killed, to be forked again on the next query, when a query
runs past its timeout or out of its memory. The worker's address space is limited to
``budget`` bytes above what the parent maps when it forks (less under an inherited
``RLIMIT_AS``).
"""

from __future__ import annotations

import multiprocessing
import os
import resource
import sys
import threading
import time
import weakref
from collections.abc import Mapping
from typing import Any, Protocol

from rdflib import Literal as RdfLiteral
from rdflib import URIRef

from graph_store.errors import SparqlError, SparqlResourceError, SparqlTimeoutError
from graph_store.rdf._sparql_backends import RawResult, Selection
from graph_store.rdf._sparql_guard import CheckedQuery, check_query

Terms = Mapping[str, URIRef | RdfLiteral]


class Backend(Protocol):
    def run(
        self,
        query: CheckedQuery,
        bindings: Terms,
        limit: int,
        cancel: threading.Event,
        selection: Selection = None,
    ) -> RawResult: ...


def can_isolate() -> bool:
    """Whether queries can run in a forked worker process (Linux)."""
    return sys.platform.startswith("linux") and "fork" in multiprocessing.get_all_start_methods()


def default_budget() -> int:
    """Half the machine's physical memory, in bytes."""
    return int(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")) // 2


def _mapped_bytes() -> int:
    """The address space this process maps now (``/proc/self/statm``; 0 where absent)."""
    try:
        with open("/proc/self/statm") as statm:
            return int(statm.read().split()[0]) * resource.getpagesize()
    except (OSError, ValueError, IndexError):
        return 0


def worker_cap(budget: int) -> int:
    """How far a worker forked now may grow: ``budget``, or less under an inherited limit."""
    soft, _hard = resource.getrlimit(resource.RLIMIT_AS)
    if soft == resource.RLIM_INFINITY:
        return budget
    return max(0, min(budget, soft - _mapped_bytes()))


class QueryWorker:
    """One view's worker process (module docstring); thread-safe, one query at a time."""

    def __init__(self, backend: Backend, budget: int) -> None:
        self._backend = backend
        self.budget = budget
        self._lock = threading.Lock()
        self._process: Any = None
        self._conn: Any = None
        self._finalizer: weakref.finalize[Any, Any] | None = None

    def run(
        self, text: str, terms: Terms, limit: int, timeout_s: float, selection: Selection = None
    ) -> RawResult:
        deadline = time.monotonic() + timeout_s
        if not self._lock.acquire(timeout=timeout_s):
            raise SparqlTimeoutError(f"the SPARQL query did not finish within {timeout_s} s")
        try:
            if self._process is None or not self._process.is_alive():
                self._start()
            self._conn.send((text, dict(terms), limit, selection))
            if not self._conn.poll(max(0.0, deadline - time.monotonic())):
                self.close()
                raise SparqlTimeoutError(f"the SPARQL query did not finish within {timeout_s} s")
            try:
                status, payload = self._conn.recv()
            except (EOFError, OSError):
                status, payload = "died", None
            if status != "ok" and status != "error":
                code = self._stop()
                grown = worker_cap(self.budget) >> 20
                raise SparqlResourceError(
                    f"the SPARQL query ran out of memory (its worker may grow {grown} MB;"
                    " narrow the query, or raise memory_mb or the address-space limit)"
                    if status == "memory" or code in (-6, -9, 134, 137)
                    else f"the SPARQL query's worker ended without an answer (exit {code})"
                )
        finally:
            self._lock.release()
        if status == "error":
            raise payload
        result: RawResult = payload
        return result

    def _start(self) -> None:
        context = multiprocessing.get_context("fork")
        parent, child = context.Pipe()
        # the parent-death signal fires when the forking *thread* ends: only the main
        # thread's lasts as long as the process (a server's request thread does not)
        bound = threading.current_thread() is threading.main_thread()
        process = context.Process(
            target=_serve, args=(self._backend, self.budget, child, os.getpid(), bound),
            name="sparql-worker", daemon=True,
        )  # fmt: skip
        process.start()
        child.close()
        self._process, self._conn = process, parent
        self._finalizer = weakref.finalize(self, _kill, process, parent)

    def _stop(self) -> int | None:
        """Kill the worker (a later query forks a new one); its exit code."""
        if self._process is None:
            return None
        process = self._process
        if self._finalizer is not None:
            self._finalizer()
        self._process = self._conn = self._finalizer = None
        code: int | None = process.exitcode
        return code

    def close(self) -> None:
        self._stop()


def _kill(process: Any, conn: Any) -> None:
    if process.is_alive():
        process.kill()
    process.join()
    conn.close()


#: How often a worker checks that its parent is alive, in seconds.
PARENT_CHECK_S = 0.5


def _die_with(parent: int, bound: bool) -> None:  # pragma: no cover - in the worker
    """End this worker when its parent process dies, even by SIGKILL: the kernel's
    parent-death signal (Linux, when the forking thread lives as long as the parent), and
    a thread that checks the parent every :data:`PARENT_CHECK_S` s. An orphaned worker
    would otherwise run its query on, hold its memory and keep a server's port."""
    if bound:
        try:
            import ctypes
            import signal

            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(1, signal.SIGKILL, 0, 0, 0)  # PR_SET_PDEATHSIG
        except (OSError, AttributeError):
            pass

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(PARENT_CHECK_S)
        os._exit(1)

    if os.getppid() != parent:  # the parent died before the signal was armed
        os._exit(1)
    threading.Thread(target=watch, name="parent-watch", daemon=True).start()


def _close_inherited_sockets(keep: int) -> None:  # pragma: no cover - in the worker
    """Close every socket the fork copied from the parent but ``keep`` (the worker's pipe):
    a server's listening socket and its clients' connections would otherwise stay open in
    the worker after the server closed them (their clients would never see the end)."""
    import stat

    try:
        names = os.listdir("/proc/self/fd")
    except OSError:
        return
    for name in names:
        fd = int(name)
        if fd == keep:
            continue
        try:
            if stat.S_ISSOCK(os.fstat(fd).st_mode):
                os.close(fd)
        except OSError:
            pass


def _serve(
    backend: Backend, budget: int, conn: Any, parent: int, bound: bool
) -> None:  # pragma: no cover - in the worker
    import faulthandler

    _close_inherited_sockets(conn.fileno())
    _die_with(parent, bound)
    faulthandler.disable()  # a dump of this process would land on the caller's stderr
    try:  # an engine that aborts on a failed allocation prints there: keep it off the
        null = os.open(os.devnull, os.O_WRONLY)  # caller's terminal (errors come by pipe)
        os.dup2(null, 2)
        mapped = _mapped_bytes()
        if mapped:
            _soft, hard = resource.getrlimit(resource.RLIMIT_AS)
            resource.setrlimit(resource.RLIMIT_AS, (mapped + worker_cap(budget), hard))
    except (OSError, ValueError):
        pass  # no /proc or no permission: the inherited limits hold
    while True:
        try:
            text, terms, limit, selection = conn.recv()
        except (EOFError, OSError):
            return
        try:
            message: tuple[str, Any] = (
                "ok", backend.run(check_query(text), terms, limit, threading.Event(), selection)
            )  # fmt: skip
        except MemoryError:
            message = ("memory", None)
        except Exception as exc:  # handed to the caller, as the thread path does
            message = ("error", exc)
        try:
            conn.send(message)
        except MemoryError:
            conn.send(("memory", None))
        except Exception:  # an error that does not pickle: its message does
            conn.send(("error", SparqlError(f"{type(message[1]).__name__}: {message[1]}")))
