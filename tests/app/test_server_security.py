"""The server answers only its own page (issue 12, findings 1 and 2), without a browser.

``naseview serve`` (``start_app``) on the bundled demo case, port 0. A request naming a
foreign host (DNS rebinding: ``evil.example.com`` resolving to 127.0.0.1) or sent from a
foreign origin's page is refused with 403 before viser serves a byte; the loopback names
get the page. A raw websocket client speaking viser's protocol sends a
``ShareUrlRequest`` exactly as viser's client does (msgpack ``{"type":
"ShareUrlRequest"}``): no tunnel is created, nothing tries to reach the share relay, the
server stays up. The real-browser version of the foreign page is
``test_foreign_origin_browser.py``.
"""

from __future__ import annotations

import http.client
import re
import socket
import threading
import time
from pathlib import Path

import msgspec
import pytest
import viser
import viser._viser
import websockets.exceptions
import websockets.sync.client
from helpers import REPO, naseview_serve

from naseview.app.guard import OriginPolicy
from naseview.app.serve import start_app
from naseview.errors import NaseviewError

SUBPROTOCOL = f"viser-v{viser.__version__}"


def get(port: int, host_header: str, origin: str | None = None,
        path: str = "/") -> tuple[int, bytes]:
    """(status, body) of an HTTP GET to 127.0.0.1:``port`` carrying ``host_header``."""
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=10)
    try:
        headers = {"Host": host_header}
        if origin is not None:
            headers["Origin"] = origin
        conn.request("GET", path, headers=headers)
        response = conn.getresponse()
        return response.status, response.read()
    finally:
        conn.close()


def ws_connect(port: int, origin: str | None,
               host_header: str | None = None) -> websockets.sync.client.ClientConnection:
    """A websocket to 127.0.0.1:``port`` as viser's client opens it (its subprotocol),
    sending ``Origin: origin`` and, optionally, a ``Host`` other than 127.0.0.1."""
    uri = f"ws://{host_header or f'127.0.0.1:{port}'}/"
    sock = socket.create_connection(("127.0.0.1", port), timeout=10)
    try:
        return websockets.sync.client.connect(
            uri, sock=sock, origin=origin, subprotocols=[SUBPROTOCOL],  # type: ignore[list-item]
            proxy=None, open_timeout=10, max_size=None, compression=None)
    except BaseException:
        sock.close()
        raise


def report_camera(ws: websockets.sync.client.ClientConnection) -> None:
    """What viser's page sends first: its camera (the server builds a tab's panels and
    scene only for a client that did)."""
    ws.send(msgspec.msgpack.encode({
        "type": "ViewerCameraMessage", "wxyz": (1.0, 0.0, 0.0, 0.0),
        "position": (0.0, 0.0, 500.0), "fov": 0.6, "near": 1.0, "far": 5000.0,
        "image_height": 600, "image_width": 800, "look_at": (0.0, 0.0, 0.0),
        "up_direction": (0.0, 1.0, 0.0)}))


def received_bytes(ws: websockets.sync.client.ClientConnection, seconds: float,
                   enough: int | None = None) -> int:
    """Bytes the server sends on ``ws`` within ``seconds`` (or until ``enough`` came)."""
    total = 0
    end = time.monotonic() + seconds
    while (left := end - time.monotonic()) > 0 and (enough is None or total < enough):
        try:
            total += len(ws.recv(timeout=left))
        except TimeoutError:
            break
    return total


def test_rebinding_host_gets_403_and_no_page(served) -> None:
    server, _ = served
    port = server.get_port()
    for host in (f"evil.example.com:{port}", f"127.0.0.1.evil.example.com:{port}",
                 "evil.example.com", f"localhost:{port + 1}", ""):
        status, body = get(port, host)
        assert status == 403, (host, status)
        assert b"<html" not in body.lower() and b"<script" not in body.lower(), host
        assert len(body) < 300, host


def test_loopback_hosts_get_the_page(served) -> None:
    server, _ = served
    port = server.get_port()
    for host in (f"localhost:{port}", f"127.0.0.1:{port}", f"LocalHost:{port}"):
        status, body = get(port, host)
        assert status == 200, (host, status)
        assert b"<html" in body.lower()
    # the page's own scripts and assets, fetched with its own Origin, are served too
    status, _ = get(port, f"127.0.0.1:{port}", origin=f"http://127.0.0.1:{port}")
    assert status == 200


def test_page_cannot_be_framed_by_another_site(served) -> None:
    server, _ = served
    port = server.get_port()
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=10)
    try:
        conn.request("GET", "/")
        response = conn.getresponse()
        response.read()
    finally:
        conn.close()
    assert response.status == 200
    assert response.getheader("X-Frame-Options") == "DENY"
    assert "frame-ancestors 'none'" in (response.getheader("Content-Security-Policy") or "")


def test_foreign_origin_websocket_is_refused(served) -> None:
    server, _ = served
    port = server.get_port()
    before = len(server.get_clients())
    for origin, host in ((f"http://localhost:{port + 7}", None),
                         ("http://evil.example.com", None),
                         ("null", None),                 # a file:// or sandboxed page
                         (f"https://127.0.0.1:{port}", None),
                         (f"http://127.0.0.1:{port}", f"evil.example.com:{port}"),
                         (f"http://evil.example.com:{port}", f"evil.example.com:{port}")):
        with pytest.raises(websockets.exceptions.InvalidStatus) as refused:
            ws_connect(port, origin, host)
        assert refused.value.response.status_code == 403, (origin, host)
    assert len(server.get_clients()) == before


def test_own_origin_websocket_receives_the_scene(served) -> None:
    server, _ = served
    port = server.get_port()
    for origin in (f"http://127.0.0.1:{port}", f"http://localhost:{port}", None):
        host = None if origin is None else origin.removeprefix("http://")
        with ws_connect(port, origin, host) as ws:
            report_camera(ws)
            assert received_bytes(ws, 10, enough=100_000) >= 100_000, origin  # the case


def test_a_socket_that_never_shows_a_page_gets_no_patient_data(served) -> None:
    """Panels and scenes are built per tab, for a client that reported its camera: a
    socket of the right origin that never does receives no mesh and no photo."""
    server, _ = served
    port = server.get_port()
    with ws_connect(port, f"http://127.0.0.1:{port}") as ws:
        assert received_bytes(ws, 3) < 20_000


def test_share_url_request_creates_no_tunnel(served, monkeypatch) -> None:
    server, _ = served
    port = server.get_port()
    attempts: list[tuple[object, ...]] = []
    reached: list[str] = []

    class RecordingTunnel:
        """Stands in for viser's share tunnel: records the attempt, never connects."""

        def __init__(self, *args: object, **kwargs: object) -> None:
            attempts.append(args)
            raise RuntimeError("test: the share tunnel must never be created")

    original = viser.ViserServer.request_share_url

    def recording_request(self: viser.ViserServer, *args: object, **kwargs: object):
        reached.append(threading.current_thread().name)
        return original(self, *args, **kwargs)

    monkeypatch.setattr(viser._viser, "ViserTunnel", RecordingTunnel)
    monkeypatch.setattr(viser.ViserServer, "request_share_url", recording_request)
    # exactly what viser's client sends for the (hidden) "Request Share URL" button
    message = msgspec.msgpack.encode({"type": "ShareUrlRequest"})
    with ws_connect(port, f"http://127.0.0.1:{port}") as ws:
        received_bytes(ws, 0.5)
        ws.send(message)
        ws.send(msgspec.msgpack.encode({"type": "ShareUrlDisconnect"}))
        ws.send(message)
        time.sleep(1.0)
        assert attempts == [] and reached == [], "a share tunnel was attempted"
        assert server._share_tunnel is None
        ws.ping().wait(5)                      # this connection is still served
    # and the server still serves a new page and a new client
    assert get(port, f"127.0.0.1:{port}")[0] == 200
    with ws_connect(port, f"http://127.0.0.1:{port}") as ws:
        report_camera(ws)
        assert received_bytes(ws, 10, enough=100_000) >= 100_000
    assert attempts == [] and reached == []


def test_wildcard_bind_accepts_ip_addresses_but_not_names() -> None:
    policy = OriginPolicy.for_bind("0.0.0.0", 8080)
    assert policy.refusal("192.168.1.20:8080", "http://192.168.1.20:8080") is None
    assert policy.refusal("evil.example.com:8080", None) is not None
    assert policy.refusal("192.168.1.20:8080", "http://evil.example.com:8080") is not None
    lan = OriginPolicy.for_bind("192.168.1.20", 8080)
    assert lan.refusal("192.168.1.20:8080", "http://192.168.1.20:8080") is None
    assert lan.refusal("192.168.1.21:8080", None) is not None


def start_error(host: str, port: int) -> str:
    """The one-line error of ``start_app(None, host, port)``, which must come within 30 s
    (viser alone waits forever for a server that cannot listen)."""
    outcome: dict[str, object] = {}

    def run() -> None:
        try:
            outcome["started"] = start_app(None, host=host, port=port, model="generic")
        except NaseviewError as e:
            outcome["error"] = str(e)

    worker = threading.Thread(target=run, daemon=True)
    worker.start()
    worker.join(30)
    assert not worker.is_alive(), f"start_app({host!r}, {port}) hangs"
    if "started" in outcome:
        server, app = outcome["started"]  # type: ignore[misc]
        app.close()
        server.stop()
        raise AssertionError(f"start_app({host!r}, {port}) served on port "
                             f"{server.get_port()} instead of refusing")
    message = str(outcome["error"])
    assert "\n" not in message
    return message


def test_busy_port_is_a_clear_error_not_another_port() -> None:
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        assert re.search(rf"port {port} .*in use.*--port", start_error("127.0.0.1", port))


def test_port_outside_range_is_a_clear_error_not_a_hang() -> None:
    assert "--port must be an integer in 0-65535" in start_error("127.0.0.1", 70000)
    assert "--port must be an integer in 0-65535" in start_error("127.0.0.1", -1)


def test_address_of_another_computer_is_a_clear_error_not_a_hang() -> None:
    # 192.0.2.1 is TEST-NET-1 (RFC 5737): never an address of this computer
    message = start_error("192.0.2.1", 0)
    assert "--host '192.0.2.1'" in message and "127.0.0.1" in message
    assert "--host 'no-such-host.invalid'" in start_error("no-such-host.invalid", 0)


def test_serve_with_host_warns_and_still_refuses_foreign_hosts() -> None:
    """``naseview serve --host`` (here 127.0.0.2: another address of this computer, so the
    test opens nothing to the network) serves the printed address, warns that other
    computers can open it, and still refuses a foreign ``Host``."""
    with naseview_serve(["--host", "127.0.0.2", "--port", "0", "--model", "generic",
                         "--no-browser"]) as lines:
        out = "".join(lines)
        found = re.search(r"serving .* at http://127\.0\.0\.2:(\d+)/", out)
        assert found, out
        assert "warning: bound to 127.0.0.2; other computers on the network" in out
        port = int(found.group(1))
        conn = http.client.HTTPConnection("127.0.0.2", port, timeout=10)
        conn.request("GET", "/")
        assert conn.getresponse().status == 200
        conn.close()
        conn = http.client.HTTPConnection("127.0.0.2", port, timeout=10)
        conn.request("GET", "/", headers={"Host": f"evil.example.com:{port}"})
        assert conn.getresponse().status == 403
        conn.close()


def test_every_viser_server_is_guarded() -> None:
    """No code path builds a bare ``viser.ViserServer``: only the guard does."""
    bare = re.compile(r"\bViserServer\s*\(")
    offenders = []
    for folder in ("naseview", "tests", "benchmarks"):
        for path in sorted((REPO / folder).rglob("*.py")):
            if path == REPO / "naseview" / "app" / "guard.py" or path == Path(__file__):
                continue
            for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
                if bare.search(line.split("#")[0]) and ">>>" not in line:
                    offenders.append(f"{path.relative_to(REPO)}:{n}")
    assert offenders == [], "use naseview.app.guard.guarded_viser_server"


def test_new_client_after_refusals_still_connects(served) -> None:
    server, _ = served
    port = server.get_port()
    for _ in range(5):
        assert get(port, f"evil.example.com:{port}")[0] == 403
    with ws_connect(port, f"http://localhost:{port}", f"localhost:{port}") as ws:
        report_camera(ws)
        assert received_bytes(ws, 10, enough=100_000) >= 100_000


def test_repeated_host_or_origin_header_is_refused_not_a_crash(served) -> None:
    """Two Host (or Origin) headers, one of them foreign: a clean 403, never a 500."""
    server, _ = served
    port = server.get_port()
    for extra in ([("Host", f"127.0.0.1:{port}"), ("Host", f"evil.example.com:{port}")],
                  [("Host", f"127.0.0.1:{port}"), ("Origin", f"http://127.0.0.1:{port}"),
                   ("Origin", "http://evil.example.com")]):
        with socket.create_connection(("127.0.0.1", port), timeout=10) as s:
            head = "".join(f"{k}: {v}\r\n" for k, v in extra)
            s.sendall(f"GET / HTTP/1.1\r\n{head}Connection: close\r\n\r\n".encode())
            reply = b""
            while chunk := s.recv(65536):
                reply += chunk
        assert reply.startswith(b"HTTP/1.1 403"), reply[:80]
        assert b"<html" not in reply.lower()
