"""A SPARQL query's worker process dies with the command that forked it, even when that
command is killed with SIGKILL mid-query (no handler runs): nothing keeps computing,
holding memory or holding the server's port."""

from __future__ import annotations

import contextlib
import signal
import socket
import subprocess
import sys
import threading
import time
import urllib.parse
import urllib.request
from pathlib import Path

import pytest

from tests.causalsplat.serve.conftest import DEMO_OBJECTS
from tests.conftest import COMMAND_TIMEOUT_S, REPO_ROOT

pytestmark = pytest.mark.skipif(
    not sys.platform.startswith("linux"), reason="forked SPARQL workers are Linux only"
)

#: Runs until its timeout on any store: a four-way cross product of every triple.
HEAVY = "SELECT (COUNT(*) AS ?n) WHERE { ?a ?b ?c . ?d ?e ?f . ?g ?h ?i . ?j ?k ?l }"


def _children(pid: int) -> set[int]:
    found = set()
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[1]) == pid:
                found.add(int(entry.name))
    return found


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def _wait(condition, what: str) -> None:  # type: ignore[no-untyped-def]
    deadline = time.monotonic() + COMMAND_TIMEOUT_S
    while not condition():
        if time.monotonic() > deadline:
            pytest.fail(what)
        time.sleep(0.05)


def _store(tmp_path: Path) -> str:
    from causalsplat import open_store

    url = f"sqlite:///{tmp_path / 'store.db'}"
    with open_store(url) as store:
        store.ingest_objects(DEMO_OBJECTS)
    return url


def _kill_and_check(proc: subprocess.Popen[str]) -> None:
    workers: set[int] = set()

    def forked() -> bool:
        workers.update(_children(proc.pid))
        return bool(workers)

    _wait(forked, "no SPARQL worker was forked")
    proc.send_signal(signal.SIGKILL)
    proc.wait()  # not communicate(): an orphaned worker would hold the pipes open
    if proc.stdout is not None:
        proc.stdout.close()
    _wait(lambda: not any(_alive(w) for w in workers), f"workers {workers} outlived their parent")


def test_killing_the_sparql_command_mid_query_ends_its_worker(tmp_path: Path) -> None:
    proc = subprocess.Popen(
        [sys.executable, "-m", "causalsplat", "sparql", HEAVY, "--timeout", "600",
         "--db", _store(tmp_path)],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, text=True, cwd=REPO_ROOT,
    )  # fmt: skip
    _kill_and_check(proc)


def test_killing_serve_mid_query_ends_its_worker_and_frees_the_port(tmp_path: Path) -> None:
    proc = subprocess.Popen(
        [sys.executable, "-m", "causalsplat", "serve", "--port", "0", "--quiet",
         "--timeout", "600", "--db", _store(tmp_path)],
        stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, cwd=REPO_ROOT,
    )  # fmt: skip
    assert proc.stdout is not None
    url = proc.stdout.readline().strip()
    port = urllib.parse.urlsplit(url).port
    body = urllib.parse.urlencode({"query": HEAVY}).encode()

    def ask() -> None:
        with contextlib.suppress(OSError):  # the server is killed under it
            urllib.request.urlopen(f"{url}sparql", data=body, timeout=COMMAND_TIMEOUT_S)

    client = threading.Thread(target=ask, daemon=True)
    client.start()
    _kill_and_check(proc)
    client.join(COMMAND_TIMEOUT_S)
    with socket.socket() as again:  # a restart can bind the port at once
        again.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        again.bind(("127.0.0.1", port))
