"""A page of another origin, in a real headless Chromium, reads ``/sparql`` when ``serve``
names its origin (``--cors``), and cannot when it does not: the browser's own CORS rules
decide, preflight included (a POST of ``application/sparql-query``).

Skipped when Chromium or Playwright is missing; under CI (``CI=true``) that fails instead.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any

import pytest

from causalsplat import open_store
from causalsplat.serve import App, Server

PAGE = b"<!doctype html><title>lab</title><p>a page of another origin</p>"
FETCH = """async ([url, method]) => {
  try {
    const init = method === "POST"
      ? {method: "POST", body: "ASK { ?s ?p ?o }",
         headers: {"Content-Type": "application/sparql-query",
                   "Accept": "application/sparql-results+json"}}
      : {headers: {"Accept": "application/sparql-results+json"}};
    const target = method === "POST" ? url : url + "?query=" + encodeURIComponent("ASK {}");
    const response = await fetch(target, init);
    return "status " + response.status + " " + JSON.stringify((await response.json()).boolean);
  } catch (error) {
    return "blocked " + error.name;
  }
}"""


@pytest.fixture(scope="module")
def lab() -> Iterator[str]:
    """Another origin: a plain server of one page on another port."""

    class Handler(BaseHTTPRequestHandler):
        def do_GET(self) -> None:
            self.send_response(200)
            self.send_header("Content-Type", "text/html")
            self.send_header("Content-Length", str(len(PAGE)))
            self.end_headers()
            self.wfile.write(PAGE)

        def log_message(self, format: str, *args: Any) -> None:
            pass

    httpd = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    thread = threading.Thread(target=httpd.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{httpd.server_address[1]}"
    finally:
        httpd.shutdown()
        httpd.server_close()


@pytest.mark.parametrize("method", ["GET", "POST"])
def test_a_page_of_another_origin_reads_sparql_only_when_allowed(
    browser: Any, lab: str, store_url: str, method: str
) -> None:
    results = {}
    for allowed in (True, False):
        with open_store(store_url, create=False) as store:
            app = App(store, cors=(lab,) if allowed else ())
            with Server(app, "127.0.0.1", 0).start() as server:
                page = browser.new_page()
                try:
                    page.goto(lab)
                    results[allowed] = page.evaluate(FETCH, [server.url + "sparql", method])
                finally:
                    page.close()
    assert results[True] == "status 200 true"
    assert results[False] == "blocked TypeError"  # the browser withheld the answer
