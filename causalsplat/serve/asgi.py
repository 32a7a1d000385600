"""The :class:`~causalsplat.serve.app.App` as an ASGI application (Starlette), for Uvicorn.

One catch-all Starlette route hands every request to :meth:`App.handle` on Starlette's
thread pool (the app's handlers block: SQL, SPARQL workers, reasoning), so a long query
holds one pool thread and never the event loop. Before that, on the loop:

* a ``Host`` header that names another machine is answered 403 unless remote clients are
  allowed (:func:`~causalsplat.serve.server.loopback_host_header`: DNS rebinding);
* a body over :data:`~causalsplat.serve.app.MAX_BODY_BYTES` is answered 413, whether its
  size is declared or it arrives in chunks, and is never held whole;
* a query string that is not UTF-8 is answered 400.

``log`` gets one line per request: client, method, path, status.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TextIO
from urllib.parse import parse_qs

from starlette.applications import Starlette
from starlette.concurrency import run_in_threadpool
from starlette.requests import Request as StarletteRequest
from starlette.responses import Response as StarletteResponse
from starlette.routing import Route

from causalsplat.serve.app import MAX_BODY_BYTES, App, Request, Response, error_response

_METHODS = ["GET", "HEAD", "POST", "PUT", "DELETE", "PATCH", "OPTIONS"]


class _TooLarge(Exception):
    """The request body went past :data:`MAX_BODY_BYTES`."""


async def _body(request: StarletteRequest) -> bytes:
    declared = request.headers.get("content-length")
    if declared is not None:
        if not declared.isdigit():
            raise ValueError("Content-Length is not a byte count")
        if int(declared) > MAX_BODY_BYTES:
            raise _TooLarge
    chunks, size = [], 0
    async for chunk in request.stream():
        size += len(chunk)
        if size > MAX_BODY_BYTES:
            raise _TooLarge
        chunks.append(chunk)
    return b"".join(chunks)


def asgi_app(
    app: App,
    *,
    host_ok: Callable[[str | None], bool] | None = None,
    log: TextIO | None = None,
) -> Starlette:
    """An ASGI application answering as ``app`` does. ``host_ok(Host header)``: whether a
    request's ``Host`` is acceptable (``None``: every one)."""

    async def endpoint(request: StarletteRequest) -> StarletteResponse:
        response = await _answer(request)
        if log is not None:
            client = request.client.host if request.client else "-"
            path = request.scope.get("raw_path", b"").decode("latin-1") or request.url.path
            log.write(f"{client} - {request.method} {path} {response.status}\n")
            log.flush()
        return StarletteResponse(
            response.body if request.method != "HEAD" else b"",
            status_code=response.status,
            headers={"Content-Length": str(len(response.body)), **response.headers},
            media_type=response.content_type,
        )

    async def _answer(request: StarletteRequest) -> Response:
        if host_ok is not None and not host_ok(request.headers.get("host")):
            return error_response(403, "this server answers requests to its loopback address only")
        try:
            body = await _body(request)
        except _TooLarge:
            return error_response(413, f"the request body is over {MAX_BODY_BYTES} bytes")
        except ValueError as exc:
            return error_response(400, str(exc))
        raw = request.scope.get("query_string", b"")
        try:
            query = parse_qs(raw.decode("utf-8"), keep_blank_values=True, errors="strict")
        except UnicodeDecodeError:
            return error_response(400, "the URL's query string is not UTF-8")
        path = request.scope.get("raw_path", b"").decode("latin-1").split("?", 1)[0]
        ours = Request(
            method=request.method,
            path=path or request.url.path,
            query=query,
            headers={k.lower(): v for k, v in request.headers.items()},
            body=body,
        )
        return await run_in_threadpool(app.handle, ours)

    return Starlette(routes=[Route("/{path:path}", endpoint, methods=_METHODS)])
