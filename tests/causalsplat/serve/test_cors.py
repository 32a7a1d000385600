"""``serve --cors ORIGIN``: ``/sparql`` answers (and its preflight allows) pages of the named
origins only; nothing else of the app is opened to other origins."""

from __future__ import annotations

from causalsplat.serve import Server
from tests.causalsplat.serve._client import request


def test_cors_headers_name_only_allowed_origins(server: Server) -> None:
    url = server.url + "sparql?query=ASK%7B%7D"
    app = server.app
    before = app.cors
    try:
        app.cors = frozenset({"https://lab.example"})
        allowed = request(url, headers={"Origin": "https://lab.example"})
        assert allowed.headers["access-control-allow-origin"] == "https://lab.example"
        assert "Origin" in allowed.headers["vary"]
        other = request(url, headers={"Origin": "https://elsewhere.example"})
        assert "access-control-allow-origin" not in other.headers
        api = request(server.url + "api/scenes", headers={"Origin": "https://lab.example"})
        assert "access-control-allow-origin" not in api.headers  # /sparql only
        pre = request(server.url + "sparql", method="OPTIONS",
                      headers={"Origin": "https://lab.example"})  # fmt: skip
        assert pre.status == 204 and "POST" in pre.headers["access-control-allow-methods"]
    finally:
        app.cors = before
