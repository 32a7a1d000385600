"""``causalsplat serve`` as a user runs it: prints its URL, answers, stops on SIGTERM."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from collections.abc import Callable

import pytest

from tests.causalsplat.serve._client import request
from tests.conftest import COMMAND_TIMEOUT_S, REPO_ROOT


def _serve(*args: str, before: tuple[str, ...] = ()) -> subprocess.Popen[str]:
    """``causalsplat [BEFORE...] serve ARGS...`` in a process of its own."""
    return subprocess.Popen(
        [sys.executable, "-m", "causalsplat", *before, "serve", *args],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=REPO_ROOT,
        env={**os.environ},
    )  # fmt: skip


def _stopped(proc: subprocess.Popen[str], how: int, check: Callable[[], None]) -> tuple[str, str]:
    """Run ``check`` against the server, then stop it with the signal ``how``; the rest of
    its stdout and its stderr. A server still running after a failed check is killed."""
    try:
        check()
        proc.send_signal(how)
        return proc.communicate(timeout=COMMAND_TIMEOUT_S)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()


@pytest.mark.parametrize("how", [signal.SIGTERM, signal.SIGINT])
def test_serve_prints_its_url_answers_and_stops_on_a_signal(store_url: str, how: int) -> None:
    proc = _serve("--port", "0", "--quiet", "--db", store_url)

    def check() -> None:
        assert proc.stdout is not None
        url = proc.stdout.readline().strip()
        assert url.startswith("http://127.0.0.1:") and url.endswith("/"), url
        scenes = request(f"{url}api/scenes").json()["scenes"]
        assert "demo-kitchen" in {s["scene_id"] for s in scenes}

    _out, err = _stopped(proc, how, check)
    assert proc.returncode == 0, err
    assert err.strip().splitlines()[-1] == "stopped"


@pytest.mark.parametrize("where", ["after", "before"])
def test_serve_json_prints_its_endpoints_on_one_line(store_url: str, where: str) -> None:
    """``serve --json`` (or ``causalsplat --json serve``): one JSON line naming the
    endpoints, each of which a real client then reaches."""
    args = ("--port", "0", "--quiet", "--db", store_url)
    proc = _serve(*args, "--json") if where == "after" else _serve(*args, before=("--json",))

    def check() -> None:
        assert proc.stdout is not None
        endpoints = json.loads(proc.stdout.readline())
        url = endpoints["url"]
        assert url.startswith("http://127.0.0.1:") and endpoints["viewer"] == url
        scenes = request(endpoints["api"]).json()["scenes"]
        assert "demo-kitchen" in {s["scene_id"] for s in scenes}
        ask = request(endpoints["sparql"] + "?query=ASK%20%7B%20%3Fs%20%3Fp%20%3Fo%20%7D",
                      headers={"Accept": "application/sparql-results+json"})  # fmt: skip
        assert ask.json()["boolean"] is True

    out, err = _stopped(proc, signal.SIGTERM, check)
    assert proc.returncode == 0, err
    assert out == ""  # the one line, nothing after it


@pytest.mark.parametrize("host", ["0.0.0.0", "192.0.2.1"])
def test_serve_refuses_an_address_that_is_not_loopback(store_url: str, host: str) -> None:
    proc = _serve("--host", host, "--port", "0", "--db", store_url)
    out, err = proc.communicate(timeout=COMMAND_TIMEOUT_S)
    assert proc.returncode != 0 and out == ""
    [line] = err.strip().splitlines()
    assert line.startswith("causalsplat: error: refusing to listen on") and "--allow-remote" in line


def test_serve_on_a_missing_store_is_one_line_and_creates_nothing(tmp_path) -> None:
    proc = _serve("--port", "0", "--db", f"sqlite:///{tmp_path / 'none.db'}")
    _out, err = proc.communicate(timeout=COMMAND_TIMEOUT_S)
    assert proc.returncode != 0 and "no store at" in err and len(err.strip().splitlines()) == 1
    assert list(tmp_path.iterdir()) == []


def test_serve_has_help() -> None:
    proc = subprocess.run([sys.executable, "-m", "causalsplat", "serve", "--help"],
                          capture_output=True, text=True, cwd=REPO_ROOT, check=True,
                          timeout=COMMAND_TIMEOUT_S)  # fmt: skip
    assert "--allow-remote" in proc.stdout and "/sparql" in proc.stdout
