"""The HTTP server around an :class:`~causalsplat.serve.app.App`: Uvicorn, on Starlette.

Uvicorn speaks HTTP/1.1 (keep-alive, chunked bodies) on an event loop; the app's blocking
handlers run on Starlette's thread pool (:mod:`causalsplat.serve.asgi`), so a long SPARQL
query does not hold up the viewer's requests. A connection must send its request's headers
within :data:`HEADER_TIMEOUT_S` and an idle one is closed after :data:`KEEP_ALIVE_S`, so
connections that send nothing cannot use up the descriptors (a server also raises its
process's soft limit of open files to the hard one); the listen queue holds
:data:`BACKLOG`. It listens on the loopback interface unless told otherwise:
:func:`check_host` refuses any other address unless ``allow_remote`` is given, since the
app has no authentication.

>>> with Server(app, port=0) as server:                 # doctest: +SKIP
...     server.start()                                  # in a background thread
...     print(server.url)                               # http://127.0.0.1:54321/
"""

from __future__ import annotations

import contextlib
import ipaddress
import signal
import socket
import threading
import time
from collections.abc import Iterator
from typing import Any, TextIO

from causalsplat.errors import CausalSplatError
from causalsplat.serve.app import App


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


#: Seconds a connection may take to send a request's headers (from its opening, or from
#: the end of its last response): a client that opens connections and sends nothing, or
#: dribbles its headers, is cut off and holds no descriptor.
HEADER_TIMEOUT_S = 10.0
#: Seconds an idle keep-alive connection is kept open after a response.
KEEP_ALIVE_S = 5
#: Connections the kernel queues before they are accepted.
BACKLOG = 2048
#: Seconds the requests in flight get to finish after a stop is asked for.
GRACE_S = 10
#: The most bytes of request line and headers read.
MAX_HEADER_BYTES = 64 * 1024


def _protocol() -> type[Any]:
    """Uvicorn's h11 protocol with a deadline for each request's headers."""
    import h11
    from uvicorn.protocols.http.h11_impl import H11Protocol

    class HeaderDeadline(H11Protocol):
        _deadline: Any = None

        def _arm(self) -> None:
            self._disarm()
            self._deadline = self.loop.call_later(HEADER_TIMEOUT_S, self._expire)

        def _disarm(self) -> None:
            if self._deadline is not None:
                self._deadline.cancel()
                self._deadline = None

        def _expire(self) -> None:
            self._deadline = None
            if self.conn.their_state is h11.IDLE and not self.transport.is_closing():
                self.transport.close()

        def connection_made(self, transport: Any) -> None:
            super().connection_made(transport)
            self._arm()

        def handle_events(self) -> None:
            super().handle_events()
            if self._deadline is not None and self.conn.their_state is not h11.IDLE:
                self._disarm()  # a request's headers are in

        def on_response_complete(self) -> None:
            super().on_response_complete()
            if not self.transport.is_closing():
                self._arm()

        def connection_lost(self, exc: Exception | None) -> None:
            self._disarm()
            super().connection_lost(exc)

    return HeaderDeadline


def _quiet_signals(base: type[Any]) -> type[Any]:
    """Uvicorn's server, stopping on SIGINT / SIGTERM without raising them again once it
    has stopped: :meth:`Server.serve_forever` then returns, whatever handler was there."""

    class Quiet(base):  # type: ignore[misc, valid-type]
        @contextlib.contextmanager
        def capture_signals(self) -> Iterator[None]:
            if threading.current_thread() is not threading.main_thread():
                yield
                return
            handled = (signal.SIGINT, signal.SIGTERM)
            previous = {sig: signal.signal(sig, self.handle_exit) for sig in handled}
            try:
                yield
            finally:
                for sig, handler in previous.items():
                    signal.signal(sig, handler)

    return Quiet


def _raise_descriptor_limit() -> None:
    """Let this process hold as many connections as its hard limit allows."""
    import resource

    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    wanted = max(soft, 65536) if hard == resource.RLIM_INFINITY else hard
    if soft < wanted:
        with contextlib.suppress(ValueError, OSError):
            resource.setrlimit(resource.RLIMIT_NOFILE, (wanted, hard))


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
        sock = socket.socket(family, socket.SOCK_STREAM)
        try:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            sock.bind((host, port))
            sock.listen(BACKLOG)
        except OSError as exc:
            sock.close()
            raise ServeError(f"cannot listen on {host}:{port}: {exc.strerror or exc}") from None
        _raise_descriptor_limit()
        import uvicorn

        from causalsplat.serve.asgi import asgi_app

        def host_ok(header: str | None) -> bool:
            return loopback_host_header(header, host)

        asgi = asgi_app(app, host_ok=None if allow_remote else host_ok, log=log)
        config = uvicorn.Config(
            asgi, log_config=None, access_log=False, lifespan="off", http=_protocol(),
            backlog=BACKLOG, timeout_keep_alive=KEEP_ALIVE_S, timeout_graceful_shutdown=GRACE_S,
            h11_max_incomplete_event_size=MAX_HEADER_BYTES, server_header=False,
            proxy_headers=False,
        )  # fmt: skip
        self._uvicorn = _quiet_signals(uvicorn.Server)(config)
        self._socket = sock
        self.app = app
        self._thread: threading.Thread | None = None

    @property
    def port(self) -> int:
        """The port listened on (the one picked, for port 0)."""
        return int(self._socket.getsockname()[1])

    @property
    def url(self) -> str:
        """``http://HOST:PORT/`` (an IPv6 address in brackets)."""
        host = str(self._socket.getsockname()[0])
        if ":" in host:
            host = f"[{host}]"
        return f"http://{host}:{self.port}/"

    def serve_forever(self) -> None:
        """Answer requests on this thread until :meth:`shutdown` (from another thread), or,
        on the main thread, until SIGINT or SIGTERM: requests in flight get
        :data:`GRACE_S` seconds to finish, then it returns."""
        self._uvicorn.run(sockets=[self._socket])

    def start(self) -> Server:
        """Answer requests on a background thread; returns ``self`` once it listens."""
        self._thread = threading.Thread(
            target=self.serve_forever, name="causalsplat-serve", daemon=True
        )
        self._thread.start()
        while not self._uvicorn.started and self._thread.is_alive():
            time.sleep(0.01)
        return self

    def shutdown(self) -> None:
        """Stop answering (requests in flight get :data:`GRACE_S` seconds) and close the
        socket."""
        self._uvicorn.should_exit = True
        if self._thread is not None:
            self._thread.join()
            self._thread = None
        self._socket.close()

    def __enter__(self) -> Server:
        return self

    def __exit__(self, *_exc: object) -> None:
        self.shutdown()
