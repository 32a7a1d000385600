"""``serve`` as an HTTP/1.1 server: keep-alive, chunked bodies, bounded bodies, and
connections that send nothing or dribble their headers cut off, so they cannot stop
other clients from being answered."""

from __future__ import annotations

import http.client
import json
import resource
import socket
import time
from collections.abc import Iterator

import pytest

from causalsplat import open_store
from causalsplat.serve import App, Server
from causalsplat.serve import server as server_module
from causalsplat.serve.app import MAX_BODY_BYTES
from tests.conftest import COMMAND_TIMEOUT_S

COUNT = "SELECT (COUNT(*) AS ?n) WHERE { ?s ?p ?o }"


@pytest.fixture
def quick_server(store_url: str, monkeypatch: pytest.MonkeyPatch) -> Iterator[Server]:
    """A server whose header deadline is 1 s (10 s by default)."""
    monkeypatch.setattr(server_module, "HEADER_TIMEOUT_S", 1.0)
    yield from _serve(store_url)


@pytest.fixture
def patient_server(store_url: str, monkeypatch: pytest.MonkeyPatch) -> Iterator[Server]:
    """A server that never cuts off an idle kept-alive connection during a test (the header
    deadline, re-armed after each response, and the keep-alive time are long)."""
    monkeypatch.setattr(server_module, "HEADER_TIMEOUT_S", COMMAND_TIMEOUT_S)
    monkeypatch.setattr(server_module, "KEEP_ALIVE_S", COMMAND_TIMEOUT_S)
    yield from _serve(store_url)


def _serve(store_url: str) -> Iterator[Server]:
    with open_store(store_url, create=False) as store:
        server = Server(App(store, limit=50, timeout_s=20.0), "127.0.0.1", 0).start()
        try:
            yield server
        finally:
            server.shutdown()


def _count(conn: http.client.HTTPConnection) -> int:
    conn.request(
        "POST", "/sparql", body=COUNT, headers={"Content-Type": "application/sparql-query"}
    )
    response = conn.getresponse()
    assert response.status == 200 and response.version == 11
    return int(json.loads(response.read())["results"]["bindings"][0]["n"]["value"])


def test_one_connection_carries_many_requests(patient_server: Server) -> None:
    conn = http.client.HTTPConnection("127.0.0.1", patient_server.port, timeout=30)
    first = _count(conn)
    sock = conn.sock
    assert [_count(conn) for _ in range(5)] == [first] * 5
    assert conn.sock is sock  # the same connection, kept alive
    conn.close()


def test_a_chunked_body_is_read_and_an_oversized_one_refused(patient_server: Server) -> None:
    conn = http.client.HTTPConnection("127.0.0.1", patient_server.port, timeout=30)
    chunks = iter([COUNT[:10].encode(), COUNT[10:].encode()])
    conn.request("POST", "/sparql", body=chunks, encode_chunked=True,
                 headers={"Content-Type": "application/sparql-query"})  # fmt: skip
    response = conn.getresponse()
    assert response.status == 200, response.read()
    response.read()
    big = (b"#" * 65536 for _ in range(MAX_BODY_BYTES // 65536 + 2))
    conn.request("POST", "/sparql", body=big, encode_chunked=True,
                 headers={"Content-Type": "application/sparql-query"})  # fmt: skip
    response = conn.getresponse()
    assert response.status == 413
    assert "over" in json.loads(response.read())["error"]
    conn.close()


def _closed_by_server(sock: socket.socket) -> bool:
    try:
        return sock.recv(4096) == b""
    except ConnectionResetError:
        return True


def test_silent_and_dribbling_connections_are_cut_off(quick_server: Server) -> None:
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    # both ends of every connection live in this process
    many = min(2000, (min(soft, hard) - 200) // 2)
    assert many >= 400, f"too few descriptors for the test ({soft})"
    silent = [socket.create_connection(("127.0.0.1", quick_server.port)) for _ in range(many)]
    dribbler = socket.create_connection(("127.0.0.1", quick_server.port))
    dribbler.sendall(b"GET /api/scenes HTTP/1.1\r\n")
    try:
        # while they hang, a client is answered
        conn = http.client.HTTPConnection("127.0.0.1", quick_server.port, timeout=30)
        assert _count(conn) > 0
        conn.close()
        time.sleep(0.5)
        dribbler.sendall(b"X-Slow: 1\r\n")  # more bytes do not move the deadline
        # after the deadline the server has closed every one of them: EOF, or a reset
        # where the close found bytes it had not read (the dribbler's last header line,
        # when the deadline came before the server read it)
        for sock in [dribbler, *silent]:
            sock.settimeout(30)
            assert _closed_by_server(sock)
    finally:
        for sock in [*silent, dribbler]:
            sock.close()
