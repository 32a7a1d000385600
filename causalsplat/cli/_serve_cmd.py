"""The ``serve`` command: the local web app (SPARQL endpoint, JSON API, viewer)."""

from __future__ import annotations

import json
import signal
import sys
from types import FrameType

import click

from causalsplat.cli._app import SECONDS, cli, db_option, fail, json_option


def _stop(signum: int, frame: FrameType | None) -> None:
    raise KeyboardInterrupt


def _origins(values: tuple[str, ...]) -> tuple[str, ...]:
    """--cors values: ``*`` or an origin, ``scheme://host[:port]`` with nothing after."""
    from urllib.parse import urlsplit

    for value in values:
        parts = urlsplit(value)
        if value != "*" and (
            parts.scheme not in ("http", "https") or not parts.netloc
            or parts.path or parts.query or parts.fragment
        ):  # fmt: skip
            fail(f"--cors {value!r} is not an origin: give scheme://host[:port] or *")
    return values


@cli.command("serve")
@click.option("--host", default="127.0.0.1", show_default=True, help="Address to listen on.")
@click.option(
    "--port", type=click.IntRange(0, 65535), default=8000, show_default=True,
    help="Port to listen on (0: a free one, printed).",
)  # fmt: skip
@click.option(
    "--allow-remote", is_flag=True,
    help="Listen on an address that is not loopback (the app has no authentication).",
)  # fmt: skip
@click.option(
    "--limit", type=click.IntRange(min=1), default=10_000, show_default=True,
    help="The most rows a SPARQL answer holds (a query giving more is refused: page it).",
)  # fmt: skip
@click.option(
    "--cors", "cors", multiple=True, metavar="ORIGIN",
    help="Let pages of ORIGIN (https://host:port, or * for any) read /sparql"
    " (repeatable; none by default).",
)  # fmt: skip
@click.option(
    "--timeout", type=SECONDS, default=30.0, show_default=True,
    help="Seconds a SPARQL query may run.",
)  # fmt: skip
@click.option("--quiet", is_flag=True, help="Do not log requests on stderr.")
@db_option
@json_option
def serve(
    host: str,
    port: int,
    allow_remote: bool,
    limit: int,
    cors: tuple[str, ...],
    timeout: float,
    quiet: bool,
    db_url: str,
    as_json: bool,
) -> None:
    """Serve a store over HTTP: a SPARQL 1.1 Protocol endpoint at /sparql, a JSON API at
    /api/scenes and a 3D viewer at /.

    Listens on 127.0.0.1 unless --host names another address and --allow-remote is
    given. Prints the URL it listens on (--json: one line {"url", "sparql", "api",
    "viewer"}) once it answers; stops on Ctrl-C or SIGTERM.
    """
    from causalsplat.api import open_store
    from causalsplat.serve import App, Server

    with open_store(db_url, create=False) as store:
        app = App(store, limit=limit, timeout_s=timeout, cors=_origins(cors))
        server = Server(app, host, port, allow_remote=allow_remote,
                        log=None if quiet else sys.stderr)  # fmt: skip
        # SIGINT too: a shell starts a background job with SIGINT ignored
        previous = {sig: signal.signal(sig, _stop) for sig in (signal.SIGINT, signal.SIGTERM)}
        click.echo(f"serving {store.graph_store.url} at {server.url} (Ctrl-C stops)", err=True)
        if as_json:
            endpoints = {"url": server.url, "sparql": f"{server.url}sparql",
                         "api": f"{server.url}api/scenes", "viewer": server.url}  # fmt: skip
            click.echo(json.dumps(endpoints))
        else:
            click.echo(server.url)
        sys.stdout.flush()
        try:
            server.serve_forever()
        except KeyboardInterrupt:
            pass
        finally:
            for sig, handler in previous.items():
                signal.signal(sig, handler)
            server.shutdown()
    click.echo("stopped", err=True)
