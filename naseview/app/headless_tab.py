"""A browser tab without a browser, for tests, benchmarks and scripted checks.

:class:`HeadlessTab` opens the server's websocket the way viser's page does (its
subprotocol, the page's own ``Origin``), reports a camera (viser counts a client as
connected only then, and the app builds the tab's :class:`~naseview.app.screen.Screen`),
and reads everything the server sends on a thread, so the tab's buffers drain like a real
page's. Nothing is decoded: the server-side handles (``app.screen_of(tab.client)``) are
what a check inspects.

Example (a served app)::

    with HeadlessTab(server) as tab:
        screen = app.screen_of(tab.client)
"""

from __future__ import annotations

import socket
import threading
import time
from types import TracebackType
from typing import Any

import msgspec
import viser
import websockets.exceptions
import websockets.sync.client
from websockets.typing import Origin

from naseview.errors import NaseviewError


class HeadlessTab:
    """One tab connected to ``server`` on websocket ``path`` (``"/"``: a normal tab).

    Args:
        server: the running ``viser.ViserServer`` (on 127.0.0.1).
        path: websocket path (``naseview.app.screen.PATIENT_SCREEN_PATH``: the patient
            screen).
        size: the window ``(width, height)`` the tab reports (px).
        timeout: seconds to wait for the server to register the tab.

    Raises:
        NaseviewError: the server did not register the tab within ``timeout``.
    """

    def __init__(self, server: viser.ViserServer, path: str = "/",
                 size: tuple[int, int] = (800, 600), timeout: float = 10.0) -> None:
        port = server.get_port()
        before = set(server.get_clients())
        sock = socket.create_connection(("127.0.0.1", port), timeout=timeout)
        self.ws = websockets.sync.client.connect(
            f"ws://127.0.0.1:{port}{path}", sock=sock, origin=Origin(f"http://127.0.0.1:{port}"),
            subprotocols=[f"viser-v{viser.__version__}"],  # type: ignore[list-item]
            proxy=None, open_timeout=timeout, max_size=None, compression=None)
        self.received_bytes = 0
        self._reader = threading.Thread(target=self._read, name="naseview-headless-tab",
                                        daemon=True)
        self._reader.start()
        self.send(type="ViewerCameraMessage", wxyz=(1.0, 0.0, 0.0, 0.0),
                  position=(0.0, 0.0, 500.0), fov=0.6, near=1.0, far=5000.0,
                  image_height=size[1], image_width=size[0], look_at=(0.0, 0.0, 0.0),
                  up_direction=(0.0, 1.0, 0.0))
        end = time.monotonic() + timeout
        while True:
            new = set(server.get_clients()) - before
            if new:
                self.client = server.get_clients()[min(new)]
                break
            if time.monotonic() > end:
                self.close()
                raise NaseviewError(f"the server on port {port} did not register a tab "
                                    f"within {timeout:g} s")
            time.sleep(0.01)

    def send(self, **message: Any) -> None:
        """Send one viser message (``type`` = its class name, then its fields)."""
        self.ws.send(msgspec.msgpack.encode(message))

    def _read(self) -> None:
        try:
            while True:
                self.received_bytes += len(self.ws.recv())
        except (websockets.exceptions.ConnectionClosed, OSError):
            return

    def close(self) -> None:
        """Close the tab as a browser does when the tab is closed."""
        try:
            self.ws.close()
        finally:
            self._reader.join(timeout=5.0)

    def __enter__(self) -> HeadlessTab:
        return self

    def __exit__(self, kind: type[BaseException] | None, value: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()


__all__ = ["HeadlessTab"]
