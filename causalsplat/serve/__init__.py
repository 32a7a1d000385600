"""``causalsplat serve``: one local web app over a store (DESIGN §10).

* ``/sparql``: a SPARQL 1.1 Protocol endpoint (:mod:`causalsplat.serve.sparql_protocol`);
* ``/api/...``: a JSON API of scenes, entities, relations, labels, ask and query
  (:mod:`causalsplat.serve.api`);
* ``/`` and ``/static/<path>``: the files of the package folder ``static/``
  (:mod:`causalsplat.serve.static`).

Layers: :class:`~causalsplat.serve.app.App` turns a :class:`Request` into a
:class:`Response` through its route table and knows nothing of sockets;
:class:`~causalsplat.serve.server.Server` is Uvicorn around it (as a Starlette application,
:mod:`causalsplat.serve.asgi`), listening on 127.0.0.1 unless told otherwise.

>>> from causalsplat import open_store
>>> from causalsplat.serve import App, Server
>>> app = App(open_store("sqlite:///scenes.db", create=False))   # doctest: +SKIP
>>> Server(app, "127.0.0.1", 8000).serve_forever()                # doctest: +SKIP

Adding a route
--------------
A handler takes the app, the request and the path's named parts, and returns a
:class:`Response` (:func:`json_response` for JSON); it raises :class:`HttpError` (or any
typed library error, mapped to 400/404/503 by :meth:`App.handle`) for bad input::

    def splats(app: App, request: Request, params: dict[str, str]) -> Response:
        scene = app.scene(params["scene_id"])      # 404 for an unknown scene
        ...
        return Response(200, data, "application/octet-stream")

Then list it in :data:`causalsplat.serve.routes.ROUTES`
(``Route("GET", "/api/scenes/{scene_id}/splats", splats)``), or add it to one app with
``app.add_route("GET", "/api/scenes/{scene_id}/splats", splats)``. A ``{name}`` part
matches one path segment; ``{name:path}`` at the end matches the rest of the path. A path
that matches a route of another method answers 405; one that matches none, 404.
"""

from causalsplat.serve.app import App, HttpError, Request, Response, Route, json_response
from causalsplat.serve.server import ServeError, Server

__all__ = [
    "App",
    "HttpError",
    "Request",
    "Response",
    "Route",
    "ServeError",
    "Server",
    "json_response",
]
