"""``causalsplat serve`` under load: many clients at once, against the server it replaced.

The store holds the packaged demo kitchen. 50 client threads (this process) each post a
4-step program (``POST /api/scenes/ID/query``: the cups resting on a table, and how many)
as fast as they are answered, for 60 s (``quick``: 5 s), against the server in a process of
its own (a fresh interpreter):

* ``uvicorn``: :class:`~causalsplat.serve.Server` (Uvicorn and Starlette), a new connection
  per request, then one kept-alive connection per client;
* ``http.server`` (the baseline, in the same run): the standard library's
  ``ThreadingHTTPServer`` around the same :class:`~causalsplat.serve.App`, HTTP/1.0 with
  its default listen queue of 5, as ``serve`` was written before.

Reported: requests answered, failed (any error or a status other than 200), latency p50 /
p99 / max, requests per second, and the server process's peak RSS. Both ends share this
machine's cores, so the figures are the pair's, and the ratio is what to compare.
"""

from __future__ import annotations

import http.client
import json
import resource
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

from causalsplat.bench import BenchReport

NAME = "serve"
CLIENTS = 50
PROGRAM = {
    "query_type": "spatial",
    "steps": [
        {"op": "scene"},
        {"op": "filter_category", "inputs": [0], "value": "cup"},
        {"op": "filter_category", "inputs": [0], "value": "table"},
        {"op": "relate", "inputs": [1, 2], "relation": "supported_by"},
    ],
    "answer_step": 3,
}


def _baseline(app: Any, port: int) -> Any:
    """The standard library's threading HTTP server around ``app`` (HTTP/1.0)."""
    from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
    from urllib.parse import parse_qs, urlsplit

    from causalsplat.serve.app import Request

    class Handler(BaseHTTPRequestHandler):
        protocol_version = "HTTP/1.0"

        def _answer(self) -> None:
            parts = urlsplit(self.path)
            length = int(self.headers.get("Content-Length") or 0)
            request = Request(
                self.command, parts.path, parse_qs(parts.query),
                {k.lower(): v for k, v in self.headers.items()}, self.rfile.read(length),
            )  # fmt: skip
            response = app.handle(request)
            self.send_response(response.status)
            self.send_header("Content-Type", response.content_type)
            self.send_header("Content-Length", str(len(response.body)))
            self.end_headers()
            self.wfile.write(response.body)

        do_GET = do_POST = _answer

        def log_message(self, format: str, *args: Any) -> None:
            pass

    class Threading(ThreadingHTTPServer):
        daemon_threads = True

    return Threading(("127.0.0.1", port), Handler)


def serve_until_told(kind: str, db: str) -> None:  # pragma: no cover - the child's side
    """The server process: print the port, answer until a line arrives on stdin, then
    print the process's peak RSS (MiB)."""
    from causalsplat import open_store
    from causalsplat.serve import App, Server

    with open_store(db, create=False) as store:
        app = App(store)
        if kind == "uvicorn":
            server = Server(app, "127.0.0.1", 0).start()
            print(server.port, flush=True)
            sys.stdin.readline()
            server.shutdown()
        else:
            httpd = _baseline(app, 0)
            thread = threading.Thread(target=httpd.serve_forever, daemon=True)
            thread.start()
            print(httpd.server_address[1], flush=True)
            sys.stdin.readline()
            httpd.shutdown()
    print(_peak_mib(), flush=True)


def _peak_mib() -> float:
    """This process's peak RSS in MiB: ``VmHWM``, which starts anew at ``exec`` (the
    ``ru_maxrss`` of a child spawned from a large process keeps the parent's, 3.7 GB)."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def _load(port: int, path: str, seconds: float, keep_alive: bool) -> dict[str, Any]:
    body = json.dumps(PROGRAM).encode()
    headers = {"Content-Type": "application/json"}
    latencies: list[float] = []
    failures: list[str] = []
    lock = threading.Lock()
    end = time.monotonic() + seconds

    def client() -> None:
        conn: http.client.HTTPConnection | None = None
        mine, bad = [], []
        while time.monotonic() < end:
            start = time.perf_counter()
            try:
                if conn is None:
                    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
                conn.request("POST", path, body=body, headers=headers)
                response = conn.getresponse()
                response.read()
                if response.status != 200:
                    bad.append(str(response.status))
                if not keep_alive or response.will_close:
                    conn.close()
                    conn = None
            except (OSError, http.client.HTTPException) as exc:
                bad.append(type(exc).__name__)
                if conn is not None:
                    conn.close()
                conn = None
            mine.append(time.perf_counter() - start)
        if conn is not None:
            conn.close()
        with lock:
            latencies.extend(mine)
            failures.extend(bad)

    threads = [threading.Thread(target=client) for _ in range(CLIENTS)]
    began = time.perf_counter()
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    wall = time.perf_counter() - began
    ordered = sorted(latencies)

    def q(p: float) -> float:
        return ordered[min(len(ordered) - 1, round(p * (len(ordered) - 1)))] if ordered else 0.0

    return {
        "requests": len(latencies),
        "failed": len(failures),
        "failures": sorted(set(failures)),
        "p50_ms": 1000 * statistics.median(latencies) if latencies else 0.0,
        "p99_ms": 1000 * q(0.99),
        "max_ms": 1000 * (ordered[-1] if ordered else 0.0),
        "per_s": len(latencies) / wall,
    }


def _run(kind: str, db: str, scene: str, seconds: float, keep_alive: bool) -> dict[str, Any]:
    # a fresh interpreter, as `causalsplat serve` is: a forked one would carry (and count
    # in its peak RSS) everything this benchmark process holds
    code = "import sys; from causalsplat.bench.serve import serve_until_told as s; s(*sys.argv[1:])"
    with subprocess.Popen(
        [sys.executable, "-c", code, kind, db],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
    ) as process:  # fmt: skip
        assert process.stdin is not None and process.stdout is not None
        try:
            port = int(process.stdout.readline())
            row = _load(port, f"/api/scenes/{scene}/query", seconds, keep_alive)
            process.stdin.write("stop\n")
            process.stdin.flush()
            row["peak_rss_mib"] = float(process.stdout.readline())
        finally:
            if process.poll() is None:
                process.stdin.close()
                process.wait(timeout=60)
    return row


def measure(seconds: float) -> dict[str, Any]:
    import tempfile

    import causalsplat
    from causalsplat import open_store

    objects = Path(causalsplat.__file__).parent / "data" / "demo_kitchen.json"
    with tempfile.TemporaryDirectory() as work:
        db = f"sqlite:///{Path(work) / 'serve.db'}"
        with open_store(db) as store:
            scene = store.ingest_objects(objects).id
        rows = {
            "http.server (baseline), a connection per request": _run(
                "baseline", db, scene, seconds, False
            ),
            "uvicorn, a connection per request": _run("uvicorn", db, scene, seconds, False),
            "uvicorn, kept-alive connections": _run("uvicorn", db, scene, seconds, True),
        }
    return {"seconds": seconds, "clients": CLIENTS, "rows": rows}


def _markdown(data: dict[str, Any]) -> str:
    rows = data["rows"]
    base = rows["http.server (baseline), a connection per request"]
    lines = [
        f"{data['clients']} clients, {data['seconds']:.0f} s each, the 4-step program of"
        " `causalsplat/bench/serve.py` on the demo kitchen; the server in a process of its"
        " own, the clients in this one.",
        "",
        "| server | requests | failed | p50 ms | p99 ms | max ms | requests/s | p99 / baseline"
        " | server peak RSS MiB |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for label, r in rows.items():
        failed = f"{r['failed']}" + (f" ({', '.join(r['failures'])})" if r["failed"] else "")
        ratio = f"{r['p99_ms'] / base['p99_ms']:.2f}x" if base["p99_ms"] else ""
        lines.append(
            f"| {label} | {r['requests']:,} | {failed} | {r['p50_ms']:.1f} | {r['p99_ms']:.1f}"
            f" | {r['max_ms']:.1f} | {r['per_s']:.0f} | {ratio} | {r['peak_rss_mib']:.0f} |"
        )
    lines += ["", "Goal: 0 failed requests and p99 under 500 ms with 50 clients for 60 s."]
    return "\n".join(lines)


def run(*, quick: bool = False) -> BenchReport:
    data = measure(5.0 if quick else 60.0)
    return BenchReport(NAME, "Serve under load: 50 clients", _markdown(data), data)
