"""Who may talk to the server: pages of its own origin, on the host names it serves.

viser accepts a websocket and serves its page to any ``Origin`` and any ``Host``: a page on
another origin (another local web app, a site the surgeon visits, a DNS-rebinding host
name that resolves to 127.0.0.1) could connect and receive the patient's photos and mesh.
:func:`guarded_viser_server` starts viser with every HTTP request and websocket handshake
checked first by :class:`OriginPolicy`:

- ``Host`` must name the server: a loopback name (``localhost``, ``127.0.0.1``, ``[::1]``)
  or the address it was deliberately bound to with ``--host``, with the server's port.
  A wildcard bind (``--host 0.0.0.0``) also accepts IP-literal hosts (rebinding needs a
  name) and this machine's own host name.
- ``Origin``, when the client sends one (every browser does), must be ``http://`` + that
  same host and port: same origin only. A client without ``Origin`` is not a web page.

Anything else gets ``403 Forbidden`` before viser sees it. Every page it does serve says
that no other site may frame it, and that it loads nothing from anywhere but itself
(:data:`PAGE_HEADERS`), and the page is titled naseview (:func:`retitled`), not "Viser".
:func:`refuse_share` disables viser's share tunnel on the server
side, whatever a client sends: a raw ``ShareUrlRequest`` message is logged and dropped,
never forwarded to the public relay.

:func:`check_listen` makes a bad ``--host`` / ``--port`` a one-line error: viser alone
would wait forever for a server that cannot listen (port 70000, an address that is not
this computer's) and silently move to the next port when the chosen one is busy.

Example
-------
>>> policy = OriginPolicy.for_bind("127.0.0.1", 8080)
>>> policy.refusal("localhost:8080", "http://localhost:8080") is None
True
>>> policy.refusal("evil.example.com:8080", None)
"Host 'evil.example.com:8080' is not this server"
>>> policy.refusal("127.0.0.1:8080", "http://localhost:9999")
"Origin 'http://localhost:9999' is not this server's page"
"""

from __future__ import annotations

import errno
import gzip
import html
import http
import ipaddress
import logging
import re
import socket
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, replace
from typing import Any
from urllib.parse import urlsplit

import viser
import viser._messages
import websockets.asyncio.server
from websockets.asyncio.server import ServerConnection
from websockets.http11 import Request, Response

from naseview.app.upload_limit import UploadLimit
from naseview.errors import NaseviewError

log = logging.getLogger(__name__)

LOOPBACK_NAMES: frozenset[str] = frozenset({"localhost", "127.0.0.1", "::1"})
WILDCARD_BINDS: frozenset[str] = frozenset({"0.0.0.0", "::", ""})
PORT_RANGE: tuple[int, int] = (0, 65535)
"""Ports ``--port`` accepts (0: any free port, chosen by the system)."""

PAGE_HEADERS: dict[str, str] = {
    # no other site may show the app inside its own page (clickjacking, UI redress)
    "X-Frame-Options": "DENY",
    # the page loads and connects only to this server (no CDN, no tracker, no relay)
    "Content-Security-Policy": ("default-src 'self' data: blob: 'unsafe-inline' "
                                "'unsafe-eval' 'wasm-unsafe-eval'; frame-ancestors 'none'; "
                                "form-action 'none'; base-uri 'none'"),
    "Cross-Origin-Resource-Policy": "same-origin",
    "X-Content-Type-Options": "nosniff",
    "Referrer-Policy": "no-referrer",
}
"""Headers added to every HTTP response the server sends."""

PAGE_TITLE = "naseview"
"""The browser tab's title of every page the server serves."""

_PATCH_LOCK = threading.Lock()


def retitled(response: Response, title: str = PAGE_TITLE) -> Response:
    """``response`` with the ``<title>`` of an HTML page replaced by ``title``.

    viser's page is titled "Viser"; the tab (and the window list, and a printed page's
    header) should say what the surgeon opened. Other responses are returned as they are;
    a gzip-encoded page is decoded, edited and encoded again, Content-Length updated.

    >>> from websockets.datastructures import Headers
    >>> page = Response(200, "OK", Headers({"Content-Type": "text/html; charset=utf-8"}),
    ...                 b"<head><title>Viser</title></head>")
    >>> retitled(page).body
    b'<head><title>naseview</title></head>'
    """
    if not response.headers.get("Content-Type", "").startswith("text/html"):
        return response
    gzipped = response.headers.get("Content-Encoding") == "gzip"
    body = gzip.decompress(response.body) if gzipped else response.body
    new = re.sub(rb"<title>[^<]*</title>", b"<title>" + html.escape(title).encode() + b"</title>",
                 body, count=1)
    if new == body:
        return response
    payload = gzip.compress(new) if gzipped else new
    headers = response.headers.copy()
    if "Content-Length" in headers:
        del headers["Content-Length"]
        headers["Content-Length"] = str(len(payload))
    return replace(response, headers=headers, body=payload)


_HOST_RE = re.compile(r"(?:\[(?P<ip6>[0-9A-Fa-f:.]+)\]|(?P<name>[A-Za-z0-9.-]+))"
                      r"(?::(?P<port>[0-9]{1,5}))?")
"""A ``Host`` header: a name, an IPv4 address or a bracketed IPv6 address, then an optional
``:port`` (RFC 9110 section 7.2), and nothing else: no user info (``evil.com@localhost``), no
path (``localhost:8080/x``), no spaces inside."""


def _split_host(value: str) -> tuple[str, int | None]:
    """``"Host"`` header value -> (lower-case name without brackets, port or None).

    Parsed strictly (:data:`_HOST_RE`); anything else gives ``("", None)``, which no
    policy accepts.

    >>> _split_host("LocalHost:8080"), _split_host("[::1]:80")
    (('localhost', 8080), ('::1', 80))
    >>> _split_host("evil.com@localhost:8080"), _split_host("localhost:8080/x")
    (('', None), ('', None))
    """
    m = _HOST_RE.fullmatch(value.strip(" \t"))
    if m is None:
        return "", None
    port = int(m["port"]) if m["port"] is not None else None
    if port is not None and port > PORT_RANGE[1]:
        return "", None
    return (m["ip6"] or m["name"]).lower(), port


def _is_ip_literal(name: str) -> bool:
    try:
        ipaddress.ip_address(name)
    except ValueError:
        return False
    return True


@dataclass(frozen=True)
class OriginPolicy:
    """The host names and port this server answers as.

    Attributes:
        names: lower-case host names (and IP literals) accepted in ``Host``.
        port: the server's port (``Host`` must carry it; browsers always send it for a
            non-default port); 0: the port each request arrived on (a server started on
            port 0 learns its port only when the system binds it).
        any_ip_literal: accept any IP-literal host (a wildcard bind, ``--host 0.0.0.0``).
    """

    names: frozenset[str]
    port: int
    any_ip_literal: bool = False

    @classmethod
    def for_bind(cls, host: str, port: int) -> OriginPolicy:
        """The policy of a server bound to ``host``:``port``."""
        bind = host.strip().strip("[]").lower()
        names = set(LOOPBACK_NAMES)
        wildcard = bind in WILDCARD_BINDS
        if wildcard:
            names.add(socket.gethostname().lower())
        else:
            names.add(bind)
        return cls(frozenset(names), int(port), any_ip_literal=wildcard)

    def host_ok(self, host_header: str | None) -> bool:
        """Whether a ``Host`` header names this server."""
        if not host_header:
            return False
        name, port = _split_host(host_header)
        if port != self.port:
            return False
        return name in self.names or (self.any_ip_literal and _is_ip_literal(name))

    def refusal(self, host_header: str | None, origin: str | None) -> str | None:
        """Why a request with these headers is refused, or None when it is allowed."""
        if not self.host_ok(host_header):
            return f"Host {host_header!r} is not this server"
        if origin is None:
            return None
        parts = urlsplit(origin.strip())
        same = (parts.scheme == "http" and parts.netloc.lower() == str(host_header).lower()
                and not parts.path.strip("/"))
        return None if same else f"Origin {origin!r} is not this server's page"


ProcessRequest = Callable[[ServerConnection, Request], "Response | None"]


def _guarded(policy: OriginPolicy, inner: ProcessRequest | None) -> ProcessRequest:
    """``process_request`` hook that refuses foreign requests, then defers to ``inner``."""

    def process_request(connection: ServerConnection, request: Request) -> Response | None:
        active = policy if policy.port else replace(policy,
                                                    port=int(connection.local_address[1]))
        hosts = request.headers.get_all("Host")
        origins = request.headers.get_all("Origin")
        if len(hosts) != 1 or len(origins) > 1:   # a smuggling attempt: never guess
            why: str | None = "the request repeats its Host or Origin header"
        else:
            why = active.refusal(hosts[0], origins[0] if origins else None)
        if why is not None:
            log.warning("naseview: refused a request for %s: %s", request.path, why)
            response = connection.respond(
                http.HTTPStatus.FORBIDDEN,
                f"naseview: {why}; open the address naseview printed\n")
        else:
            answer = inner(connection, request) if inner is not None else None
            if answer is None:            # a websocket handshake of this server's page
                return None
            response = retitled(answer)
        for name, value in PAGE_HEADERS.items():
            response.headers[name] = value
        return response

    return process_request


@contextmanager
def _patched_serve(policy: OriginPolicy) -> Iterator[None]:
    """While viser starts its server, wrap ``websockets`` ``serve`` with the policy.

    viser 1.1 calls ``websockets.asyncio.server.serve(..., process_request=...)`` from its
    server thread while :class:`viser.ViserServer` is being constructed (the constructor
    waits for that thread to be listening), so the patch is needed only for that window.
    """
    original = websockets.asyncio.server.serve

    def serve(*args: Any, **kwargs: Any) -> Any:
        kwargs["process_request"] = _guarded(policy, kwargs.get("process_request"))
        return original(*args, **kwargs)

    with _PATCH_LOCK:
        websockets.asyncio.server.serve = serve  # type: ignore[misc,assignment]
        try:
            yield
        finally:
            websockets.asyncio.server.serve = original  # type: ignore[misc]


def refuse_share(server: viser.ViserServer) -> None:
    """Make the share tunnel impossible on ``server``, whatever a client sends."""

    def refused(*_args: Any, **_kwargs: Any) -> None:
        log.warning("naseview: a client asked for a public share URL; refused (patient "
                    "data never leaves this computer)")
        return None

    # The message handlers call ``self.request_share_url`` at call time: replacing the
    # bound method on the instance covers them and any later direct call.
    server.request_share_url = refused  # type: ignore[method-assign]
    websock = server._websock_server  # viser 1.1 internals, pinned in pyproject
    for message in (viser._messages.ShareUrlRequest, viser._messages.ShareUrlDisconnect):
        if message in websock._incoming_handlers:
            websock.unregister_handler(message)
    websock.register_handler(viser._messages.ShareUrlRequest,
                             lambda _client_id, _msg: refused())


def _client_error(client_id: Any, message: Any, e: Exception) -> None:
    """One log line for a client message viser could not apply (a client's error)."""
    log.warning("naseview: refused a %s from client %s: %s", type(message).__name__,
                client_id, " ".join(f"{type(e).__name__}: {e}".split())[:300])


def _quiet(handle: Callable[[Any, Any], Any]) -> Callable[[Any, Any], Any]:
    """``_handle_incoming_message`` that logs a client's bad message in one line.

    viser applies a message on the event loop (its fields to a GUI element, a camera, a
    transfer); a message with a wrong value ("abc" for a slider, an unknown field, a
    number where an object belongs) raises there, and asyncio printed "Task exception
    was never retrieved" with a full traceback. naseview's own callbacks do not run here
    (viser runs them in its thread pool, each behind the app's error handler), so what
    raises here comes from what the client sent."""

    async def quiet(client_id: Any, message: Any) -> None:
        try:
            await handle(client_id, message)
        except Exception as e:
            _client_error(client_id, message, e)

    return quiet


class _UndecodableMessage(logging.Filter):
    """On ``websockets.server``: a connection closed because the client sent bytes that
    are not a viser message (an unknown type, a missing field) is one line, not a
    traceback; any other failure of a connection handler keeps its traceback."""

    def filter(self, record: logging.LogRecord) -> bool:
        exc = record.exc_info[1] if record.exc_info else None
        if exc is None or record.getMessage() != "connection handler failed":
            return True
        tb = exc.__traceback__
        frames = []
        while tb is not None:
            frames.append(tb.tb_frame.f_code.co_name)
            tb = tb.tb_next
        if "deserialize" in frames:
            record.msg = ("naseview: closed a connection whose client sent a message that "
                          "is not viser's (%s)")
            record.args = (" ".join(f"{type(exc).__name__}: {exc}".split())[:300],)
            record.levelno, record.levelname = logging.WARNING, "WARNING"
            record.exc_info, record.exc_text = None, None
        return True


_UNDECODABLE = _UndecodableMessage()


def quiet_client_errors(server: viser.ViserServer) -> None:
    """Make a client's bad message one log line on ``server``, on every connection."""
    websock = server._websock_server
    websock._handle_incoming_message = _quiet(  # type: ignore[method-assign,assignment]
        websock._handle_incoming_message)

    async def on_connect(conn: Any) -> None:
        conn._handle_incoming_message = _quiet(conn._handle_incoming_message)

    websock.on_client_connect(on_connect)
    logger = logging.getLogger("websockets.server")
    if _UNDECODABLE not in logger.filters:
        logger.addFilter(_UNDECODABLE)


def _busy(host: str, port: int) -> NaseviewError:
    return NaseviewError(f"port {port} on {host} is in use (another naseview or another "
                         "program); stop it or pass a free --port")


def check_listen(host: str, port: int) -> None:
    """Fail with one line when a server cannot listen on ``host``:``port``.

    Binds (and releases) every address ``host`` resolves to, as the server will.

    Raises:
        NaseviewError: ``port`` outside :data:`PORT_RANGE`, the port in use, or ``host``
            not an address of this computer.
    """
    lo, hi = PORT_RANGE
    if isinstance(port, bool) or not isinstance(port, int) or not lo <= port <= hi:
        raise NaseviewError(f"--port must be an integer in {lo}-{hi} (0: any free port), "
                            f"got {port!r}")
    fix = ("use the default 127.0.0.1 (this computer only) or one of this computer's own "
           "network addresses")
    try:
        infos = list(dict.fromkeys(socket.getaddrinfo(
            host or None, port, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE)))
    except (socket.gaierror, UnicodeError) as e:
        raise NaseviewError(f"--host {host!r} is not a known address ({e}); {fix}") from None
    for family, kind, proto, _name, address in infos:
        with socket.socket(family, kind, proto) as probe:
            probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as asyncio does
            if family == socket.AF_INET6 and hasattr(socket, "IPPROTO_IPV6"):
                probe.setsockopt(socket.IPPROTO_IPV6, socket.IPV6_V6ONLY, 1)
            try:
                probe.bind(address)
            except OSError as e:
                if e.errno == errno.EADDRINUSE:
                    raise _busy(host, port) from None
                if e.errno == errno.EACCES:
                    raise NaseviewError(f"--port {port} needs administrator rights on this "
                                        "system; pass a --port above 1023") from None
                raise NaseviewError(f"--host {host!r}: cannot listen on {address[0]} "
                                    f"({e.strerror}); {fix}") from None


def guarded_viser_server(host: str, port: int, **kwargs: Any) -> viser.ViserServer:
    """A :class:`viser.ViserServer` on ``host``:``port`` that answers only its own origin.

    Args:
        host: the address to bind (127.0.0.1 unless the user chose otherwise).
        port: the port, in :data:`PORT_RANGE`; 0: any free port (``get_port()`` says
            which; every request is checked against the port it arrived on).
        **kwargs: passed to :class:`viser.ViserServer`.
    Returns:
        the started server, with :func:`refuse_share` applied, the share button hidden
        and the upload limit on every connection (:class:`UploadLimit`).
    Raises:
        NaseviewError: see :func:`check_listen`; a busy port is an error, never a silent
            move to the next one.
    """
    check_listen(host, port)
    policy = OriginPolicy.for_bind(host, port)
    with _patched_serve(policy):
        server = viser.ViserServer(host=host, port=port, **kwargs)
    if port and server.get_port() != port:  # taken in the moment since check_listen
        server.stop()                       # (its requests were refused: wrong port)
        raise _busy(host, port)
    refuse_share(server)
    quiet_client_errors(server)
    UploadLimit.install(server)        # every connection, before any tab can connect
    server.gui.configure_theme(show_share_button=False)
    return server
