"""Files of the package folder ``causalsplat/serve/static/`` at ``/static/<path>``, and ``/``.

A path is served only when every segment is a plain name (no ``..``, ``.``, empty segment,
backslash or NUL) and the file it resolves to, links followed, lies inside the folder.
``/`` answers ``static/index.html``, or a short page that lists the endpoints when the
package has none.
"""

from __future__ import annotations

import mimetypes
from pathlib import Path

from causalsplat.serve.app import App, HttpError, Request, Response

STATIC_DIR = Path(__file__).resolve().parent / "static"

#: Media types by suffix, ahead of :mod:`mimetypes` (whose table depends on the machine).
_TYPES = {
    ".html": "text/html; charset=utf-8",
    ".js": "text/javascript; charset=utf-8",
    ".mjs": "text/javascript; charset=utf-8",
    ".css": "text/css; charset=utf-8",
    ".json": "application/json",
    ".map": "application/json",
    ".wasm": "application/wasm",
    ".svg": "image/svg+xml",
    ".png": "image/png",
    ".ico": "image/x-icon",
    ".txt": "text/plain; charset=utf-8",
}

_FALLBACK_INDEX = """<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>CausalSplat</title></head>
<body><h1>CausalSplat</h1>
<ul>
<li><a href="/api/scenes">/api/scenes</a>: the stored scenes (JSON)</li>
<li><code>/api/scenes/{id}</code>, <code>/entities</code>, <code>/relations</code>,
<code>/labels</code>; POST <code>/ask</code>, <code>/query</code></li>
<li><code>/sparql</code>: SPARQL 1.1 Protocol endpoint (read-only)</li>
</ul></body></html>
"""


def media_type(path: Path) -> str:
    """The ``Content-Type`` of a static file.

    >>> media_type(Path("app.js")), media_type(Path("splat.wasm"))
    ('text/javascript; charset=utf-8', 'application/wasm')
    """
    suffix = path.suffix.lower()
    if suffix in _TYPES:
        return _TYPES[suffix]
    guessed, _ = mimetypes.guess_type(path.name)
    return guessed or "application/octet-stream"


def resolve_static(root: Path, relative: str) -> Path | None:
    """The file ``relative`` (``/``-separated, decoded) names under ``root``, or ``None``.

    >>> resolve_static(STATIC_DIR, "../app.py") is None
    True
    """
    segments = relative.split("/")
    for segment in segments:
        if segment in ("", ".", "..") or "\\" in segment or "\0" in segment:
            return None
    base = root.resolve()
    target = base.joinpath(*segments).resolve()
    if not target.is_relative_to(base) or not target.is_file():
        return None
    return target


def static_file(app: App, request: Request, params: dict[str, str]) -> Response:
    relative = params["path"]
    target = resolve_static(STATIC_DIR, relative)
    if target is None:
        raise HttpError(404, f"no static file {relative!r}")
    response = Response(200, target.read_bytes(), media_type(target))
    response.headers["Cache-Control"] = "no-cache"
    return response


def index(app: App, request: Request, params: dict[str, str]) -> Response:
    target = resolve_static(STATIC_DIR, "index.html")
    body = target.read_bytes() if target is not None else _FALLBACK_INDEX.encode("utf-8")
    response = Response(200, body, "text/html; charset=utf-8")
    response.headers["Cache-Control"] = "no-cache"
    return response
