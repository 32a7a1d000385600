"""The web app without its server: requests in, responses out, through a route table.

:class:`App` knows nothing of sockets; :mod:`causalsplat.serve.server` feeds it the
requests an HTTP server reads. Every error becomes a JSON body ``{"error": "one line"}``
with a status that says whose fault it was: 400 for bad input (a malformed query, an
update, an unknown relation), 404 for an unknown scene or path, 405 for a method a path
does not take, 406 when no result format the client accepts exists, 503 when a query ran
out of time or memory. 500 is kept for bugs.
"""

from __future__ import annotations

import json
import re
import sys
import threading
import traceback
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any
from urllib.parse import unquote

from causalsplat.errors import CausalSplatError
from graph_store.errors import (
    EntityNotFound,
    GraphStoreError,
    SceneNotFound,
    SparqlTimeoutError,
    StoreConnectionError,
)
from queries.errors import QueryError

if TYPE_CHECKING:
    from causalsplat.api import Scene, Store

#: The most bytes of request body the app reads (a query, a program, a question).
MAX_BODY_BYTES = 1 << 20


class HttpError(CausalSplatError):
    """An error with the HTTP status to answer it with (the message is the body's one line)."""

    def __init__(self, status: int, message: str) -> None:
        super().__init__(message)
        self.status = status


@dataclass(frozen=True, slots=True)
class Request:
    """One HTTP request.

    Attributes:
        method: ``"GET"``, ``"POST"``...
        path: the URL path, percent-encoded as sent (``/api/scenes/a%20b``).
        query: the URL's query parameters, each name with all its values in order.
        headers: header values by lower-case name.
        body: the request body (empty for GET).
    """

    method: str
    path: str
    query: Mapping[str, list[str]] = field(default_factory=dict)
    headers: Mapping[str, str] = field(default_factory=dict)
    body: bytes = b""

    def header(self, name: str, default: str = "") -> str:
        """The value of header ``name`` (any case), or ``default``."""
        return self.headers.get(name.lower(), default)

    @property
    def media_type(self) -> str:
        """The request's ``Content-Type`` without parameters, lower case (``""``: none)."""
        return self.header("content-type").split(";", 1)[0].strip().lower()

    def json(self) -> Any:
        """The body decoded as JSON; :class:`HttpError` 415 unless it is sent as
        ``application/json`` (a form or ``text/plain`` body is what a page of another
        origin can send without asking first: refused, never run), 400 when it is not
        JSON."""
        from causalsplat._json import JSONInputError, decode_json

        if self.media_type != "application/json":
            raise HttpError(
                415, f"send the body as application/json, not {self.media_type or 'untyped'}"
            )
        try:
            return decode_json(self.body)
        except JSONInputError as exc:
            raise HttpError(400, f"the request body is {exc}") from None


@dataclass(slots=True)
class Response:
    """One HTTP response: status, body and its media type, and extra headers."""

    status: int
    body: bytes
    content_type: str
    headers: dict[str, str] = field(default_factory=dict)


def json_response(document: Any, status: int = 200) -> Response:
    """A response whose body is ``document`` as UTF-8 JSON."""
    body = json.dumps(document, ensure_ascii=False, allow_nan=False).encode("utf-8")
    return Response(status, body, "application/json")


def error_response(status: int, message: str) -> Response:
    """``{"error": message}`` (first line only) with ``status``."""
    line = message.strip().splitlines()[0] if message.strip() else "error"
    return json_response({"error": line}, status)


#: A route's handler: the app, the request, and the path's named parts (percent-decoded).
Handler = Callable[["App", Request, dict[str, str]], Response]


@dataclass(frozen=True, slots=True)
class Route:
    """``method`` and path ``pattern`` (``/api/scenes/{scene_id}``) answered by ``handler``.

    A ``{name}`` part matches one path segment (no ``/``); the handler gets it decoded. A
    pattern ending in ``{name:path}`` matches the rest of the path, slashes included.
    """

    method: str
    pattern: str
    handler: Handler
    regex: re.Pattern[str] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "regex", _compile(self.pattern))

    def match(self, path: str) -> dict[str, str] | None:
        found = self.regex.fullmatch(path)
        if found is None:
            return None
        return {k: unquote(v, errors="strict") for k, v in found.groupdict().items()}


def _compile(pattern: str) -> re.Pattern[str]:
    parts = re.split(r"\{(\w+)(:path)?\}", pattern)
    out = []
    for i in range(0, len(parts), 3):
        out.append(re.escape(parts[i]))
        if i + 1 < len(parts):
            name, rest = parts[i + 1], parts[i + 2]
            out.append(f"(?P<{name}>.+)" if rest else f"(?P<{name}>[^/]+)")
    return re.compile("".join(out))


class App:
    """The served store and its routes (see :mod:`causalsplat.serve`).

    ``limit`` and ``timeout_s`` bound every SPARQL query, as ``causalsplat sparql``'s
    ``--limit`` and ``--timeout`` do. Handlers run on the server's threads: they reach the
    store through :meth:`scene` and :meth:`locked`, which keep one scene handle per scene
    (its graph, RDF view and reasoner stay loaded between requests) and serialise the work
    that shares state.
    """

    def __init__(
        self,
        store: Store,
        *,
        routes: Iterable[Route] | None = None,
        limit: int = 10_000,
        timeout_s: float = 30.0,
        cors: Iterable[str] = (),
    ) -> None:
        from causalsplat.serve.routes import ROUTES

        self.store = store
        self.limit = limit
        self.timeout_s = timeout_s
        #: Origins whose pages may read ``/sparql`` (``serve --cors``); none by default.
        self.cors = frozenset(cors)
        self.routes: list[Route] = list(ROUTES if routes is None else routes)
        self._work_lock = threading.RLock()
        self._handles_lock = threading.Lock()
        self._scenes: dict[str, tuple[object, Scene]] = {}

    def add_route(self, method: str, pattern: str, handler: Handler) -> None:
        """Answer ``method`` requests for paths matching ``pattern`` with ``handler``."""
        self.routes.append(Route(method.upper(), pattern, handler))

    def locked(self) -> threading.RLock:
        """The lock handlers hold while a scene handle works (reasoning, programs): a handle
        caches its reasoner and query state, which are not shared between threads."""
        return self._work_lock

    def scene(self, scene_id: str) -> Scene:
        """The handle on a stored scene, reused while the stored scene is unchanged.

        Raises ``SceneNotFound`` (404) for an unknown id.
        """
        with self._handles_lock:
            try:
                summary = self.store.graph_store.scene_summary(scene_id)
            except SceneNotFound:
                raise SceneNotFound(f"no scene {scene_id!r} in the store") from None
            cached = self._scenes.get(scene_id)
            if cached is not None and cached[0] == summary.created_at:
                return cached[1]
            handle = self.store.scene(scene_id)
            self._scenes[scene_id] = (summary.created_at, handle)
            return handle

    def cors_origin(self, request: Request) -> str | None:
        """The request's ``Origin`` when it may read ``/sparql`` (:attr:`cors`), else None."""
        origin = request.header("origin")
        if request.path != "/sparql" or not origin:
            return None
        return origin if origin in self.cors or "*" in self.cors else None

    def handle(self, request: Request) -> Response:
        """The response to ``request``: its route's, or an error response; a ``/sparql``
        response names an allowed origin (:meth:`cors_origin`)."""
        response = self._respond(request)
        origin = self.cors_origin(request)
        if origin is not None:
            response.headers["Access-Control-Allow-Origin"] = origin
            response.headers["Vary"] = ", ".join(
                v for v in (response.headers.get("Vary"), "Origin") if v
            )
        return response

    def _respond(self, request: Request) -> Response:
        try:
            return self._dispatch(request)
        except HttpError as exc:
            return error_response(exc.status, str(exc))
        except (SceneNotFound, EntityNotFound) as exc:
            return error_response(404, _message(exc))
        except SparqlTimeoutError as exc:
            return error_response(503, _message(exc))
        except StoreConnectionError as exc:
            return error_response(503, _message(exc))
        except (CausalSplatError, GraphStoreError, QueryError) as exc:
            return error_response(400, _message(exc))
        except Exception as exc:
            traceback.print_exc(file=sys.stderr)
            return error_response(500, f"internal error: {type(exc).__name__}: {exc}")

    def _dispatch(self, request: Request) -> Response:
        allowed: set[str] = set()
        path = request.path
        for route in self.routes:
            try:
                params = route.match(path)
            except UnicodeDecodeError:
                raise HttpError(400, f"the path {path!r} is not UTF-8 when decoded") from None
            if params is None:
                continue
            if route.method == request.method or (
                route.method == "GET" and request.method == "HEAD"
            ):
                return route.handler(self, request, params)
            allowed.add(route.method)
        if allowed:
            methods = ", ".join(sorted(allowed))
            response = error_response(
                405, f"{request.method} is not allowed on {path}: use {methods}"
            )
            response.headers["Allow"] = methods
            return response
        raise HttpError(404, f"no such path: {path}")


def _message(exc: BaseException) -> str:
    text = str(exc)
    if isinstance(exc, KeyError) and len(exc.args) == 1 and isinstance(exc.args[0], str):
        text = exc.args[0]  # KeyError's str() quotes its message
    return text or type(exc).__name__
