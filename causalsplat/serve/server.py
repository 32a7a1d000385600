"""The HTTP server around an :class:`~causalsplat.serve.app.App` (the standard library's).

``http.server.ThreadingHTTPServer`` answers each connection on its own thread, which is
what a local endpoint needs: a long SPARQL query does not hold up the viewer's requests.
It listens on the loopback interface unless told otherwise: :func:`check_host` refuses
any other address unless ``allow_remote`` is given, since the app has no authentication.

>>> with Server(app, port=0) as server:                 # doctest: +SKIP
...     server.start()                                  # in a background thread
...     print(server.url)                               # http://127.0.0.1:54321/
"""

from __future__ import annotations

import ipaddress
import socket
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any, TextIO
from urllib.parse import parse_qs, urlsplit

from causalsplat.errors import CausalSplatError
from causalsplat.serve.app import MAX_BODY_BYTES, App, Request, error_response


class ServeError(CausalSplatError):
    """The server cannot start as asked (an address that is not loopback, a port in use)."""


def is_loopback(host: str) -> bool:
    """Whether every address ``host`` names is a loopback address.

    >>> is_loopback("127.0.0.1"), is_loopback("::1"), is_loopback("0.0.0.0")
    (True, True, False)
    """
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        pass
    try:
        infos = socket.getaddrinfo(host, None, proto=socket.IPPROTO_TCP)
    except (OSError, UnicodeError):
        return False
    addresses = {str(info[4][0]).split("%", 1)[0] for info in infos}
    return bool(addresses) and all(ipaddress.ip_address(a).is_loopback for a in addresses)


def check_host(host: str, *, allow_remote: bool) -> None:
    """Raise :class:`ServeError` unless ``host`` is loopback or ``allow_remote`` is set."""
    if not host:
        raise ServeError("the host is empty: give an address such as 127.0.0.1")
    if not allow_remote and not is_loopback(host):
        raise ServeError(
            f"refusing to listen on {host}, which is not a loopback address: the server has"
            " no authentication and its endpoints read the whole store (pass --allow-remote"
            " to listen there anyway)"
        )


def _host_name(header: str) -> str:
    """The host of a ``Host`` header, without its port or IPv6 brackets.

    >>> _host_name("127.0.0.1:8000"), _host_name("[::1]:8000"), _host_name("localhost")
    ('127.0.0.1', '::1', 'localhost')
    """
    header = header.strip().lower()
    if header.startswith("["):
        return header[1:].split("]", 1)[0]
    return header.rsplit(":", 1)[0] if header.count(":") == 1 else header


def loopback_host_header(header: str | None, bound: str) -> bool:
    """Whether a request's ``Host`` names this machine's loopback interface (or ``bound``).

    A web page cannot make a browser send such a request to another site's server, but
    DNS rebinding can point a page's own name at 127.0.0.1; the server then sees that name
    in ``Host`` and refuses the request.

    >>> loopback_host_header("localhost:8000", "127.0.0.1")
    True
    >>> loopback_host_header("attacker.example:8000", "127.0.0.1")
    False
    """
    if not header:
        return True  # HTTP/1.0 clients may leave it out; a browser always sends it
    name = _host_name(header)
    if name in ("localhost", bound.lower()) or name.endswith(".localhost"):
        return True
    try:
        return ipaddress.ip_address(name).is_loopback
    except ValueError:
        return False


class _HTTPServer(ThreadingHTTPServer):
    daemon_threads = True  # a request still running does not keep the process alive
    app: App
    log: TextIO | None
    host: str
    check_host_header: bool


class _Handler(BaseHTTPRequestHandler):
    server: _HTTPServer
    server_version = "causalsplat"
    protocol_version = "HTTP/1.0"

    def _answer(self) -> None:
        app = self.server.app
        parts = urlsplit(self.path)
        if self.server.check_host_header and not loopback_host_header(
            self.headers.get("Host"), self.server.host
        ):
            return self._send(
                error_response(403, "this server answers requests to its loopback address only")
            )
        length_text = self.headers.get("Content-Length")
        body = b""
        if length_text is not None:
            try:
                length = int(length_text)
            except ValueError:
                length = -1
            if length < 0:
                return self._send(error_response(400, "Content-Length is not a byte count"))
            if length > MAX_BODY_BYTES:
                return self._send(
                    error_response(413, f"the request body is over {MAX_BODY_BYTES} bytes")
                )
            body = self.rfile.read(length)
        elif self.headers.get("Transfer-Encoding"):
            return self._send(error_response(411, "send the body with a Content-Length"))
        try:
            query = parse_qs(parts.query, keep_blank_values=True, errors="strict")
        except UnicodeDecodeError:
            return self._send(error_response(400, "the URL's query string is not UTF-8"))
        request = Request(
            method=self.command,
            path=parts.path,
            query=query,
            headers={k.lower(): v for k, v in self.headers.items()},
            body=body,
        )
        self._send(app.handle(request))

    def _send(self, response: Any) -> None:
        self.send_response(response.status)
        self.send_header("Content-Type", response.content_type)
        self.send_header("Content-Length", str(len(response.body)))
        for name, value in response.headers.items():
            self.send_header(name, value)
        self.end_headers()
        if self.command != "HEAD":
            self.wfile.write(response.body)

    do_GET = do_POST = do_HEAD = do_PUT = do_DELETE = do_PATCH = do_OPTIONS = _answer

    def log_message(self, format: str, *args: Any) -> None:
        log = self.server.log
        if log is not None:
            log.write(f"{self.address_string()} - {format % args}\n")
            log.flush()


class Server:
    """An HTTP server for ``app`` on ``host:port`` (port 0: a free one; see :attr:`url`).

    Raises :class:`ServeError` for an address that is not loopback without
    ``allow_remote``, or one that cannot be listened on. Without ``allow_remote``, a
    request whose ``Host`` header names another machine is refused with 403 (see
    :func:`loopback_host_header`). ``log``: where one line per request goes (``None``:
    nowhere).
    """

    def __init__(
        self,
        app: App,
        host: str = "127.0.0.1",
        port: int = 0,
        *,
        allow_remote: bool = False,
        log: TextIO | None = None,
    ) -> None:
        check_host(host, allow_remote=allow_remote)
        if not 0 <= port <= 65535:
            raise ServeError(f"the port must be 0..65535, got {port}")
        family = socket.AF_INET
        try:
            infos = socket.getaddrinfo(host, port, proto=socket.IPPROTO_TCP)
            family = infos[0][0]
        except (OSError, UnicodeError) as exc:
            raise ServeError(f"cannot listen on {host}: {exc}") from None

        class Bound(_HTTPServer):
            address_family = family

        try:
            self._httpd = Bound((host, port), _Handler)
        except OSError as exc:
            raise ServeError(f"cannot listen on {host}:{port}: {exc.strerror or exc}") from None
        self._httpd.app = app
        self._httpd.log = log
        self._httpd.host = host
        self._httpd.check_host_header = not allow_remote
        self.app = app
        self._thread: threading.Thread | None = None

    @property
    def port(self) -> int:
        """The port listened on (the one picked, for port 0)."""
        return int(self._httpd.server_address[1])

    @property
    def url(self) -> str:
        """``http://HOST:PORT/`` (an IPv6 address in brackets)."""
        host = str(self._httpd.server_address[0])
        if ":" in host:
            host = f"[{host}]"
        return f"http://{host}:{self.port}/"

    def serve_forever(self) -> None:
        """Answer requests on this thread until :meth:`shutdown` (from another thread)."""
        self._httpd.serve_forever(poll_interval=0.2)

    def start(self) -> Server:
        """Answer requests on a background thread; returns ``self``."""
        self._thread = threading.Thread(
            target=self.serve_forever, name="causalsplat-serve", daemon=True
        )
        self._thread.start()
        return self

    def shutdown(self) -> None:
        """Stop answering and close the socket (requests in flight run on, on their threads)."""
        if self._thread is not None:
            self._httpd.shutdown()
            self._thread.join()
            self._thread = None
        self._httpd.server_close()

    def __enter__(self) -> Server:
        return self

    def __exit__(self, *_exc: object) -> None:
        self.shutdown()
