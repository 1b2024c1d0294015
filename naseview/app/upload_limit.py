"""Upload limit of a server, applied while a file streams in, on every connection.

How viser (1.1) delivers a file: the browser sends one ``FileTransferStartUpload`` message
(file name, declared ``size_bytes``, ``part_count``) naming an input element, and then,
without waiting for any answer, ``FileTransferPart`` messages of 512 KiB. The GUI that owns
the element (the server's, or one tab's) keeps every part in its
``_current_file_upload_states[transfer]`` and joins them only once all parts are in. viser
accepts a transfer for *any* input element (a slider, a text field...), has no size
option, and nothing bounds a client whose parts exceed what it declared: on its own, a
client could stream without bound into any viewer tab.

One :class:`UploadLimit` per server (:meth:`UploadLimit.install`, done by
:func:`naseview.app.guard.guarded_viser_server` when the server starts) adds handlers
after viser's own: on the server's GUI, and on every connection as it opens (each tab's
GUI). So the limit holds on every connection whatever element a transfer names, whether
or not a new-patient page is open:

- a transfer naming an element that is not a watched upload button
  (:meth:`UploadLimit.watch`) is dropped at its first message: naseview has no other
  upload;
- a declared size over ``max_bytes`` (or a malformed announcement) is refused at once:
  the buffer is dropped, so every part that follows is discarded as it arrives;
- on each part, the bytes received so far are compared with the declared size and with
  the limit, and the transfer is dropped the moment either is exceeded;
- at most ``max_in_flight`` transfers stream at once *for the whole server* (all tabs
  together), so parallel uploads from several tabs cannot add up: at most
  ``max_in_flight * max_bytes`` are ever held.

A refused upload gets a final acknowledgement, so the browser's upload button is usable
again at once, and the button's ``on_refused`` is told in one line saying what happened
(too large, more than announced, or too many uploads at once). A transfer naming no
watched button is logged in one line.
"""

from __future__ import annotations

import logging
import threading
import weakref
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import viser
from viser._messages import FileTransferPart, FileTransferPartAck, FileTransferStartUpload

from naseview.intake.photos import MAX_UPLOAD_BYTES, upload_too_large

log = logging.getLogger(__name__)

Refused = Callable[[viser.ClientHandle | None, str], None]
"""``on_refused(client, one-line message)``."""

MAX_IN_FLIGHT = 4
"""Uploads that may stream at once on one server, all tabs together (one per photo
button of one new-patient page is what a surgeon does)."""

_LIMITS: weakref.WeakKeyDictionary[viser.ViserServer, UploadLimit] = (
    weakref.WeakKeyDictionary())
_LIMITS_LOCK = threading.Lock()


@dataclass
class _Transfer:
    client_id: int
    button: str
    filename: str
    declared: int
    states: dict[str, Any]          # the viser GUI's buffer dict that holds the transfer


def _mb(nbytes: int) -> str:
    return f"{nbytes / 2**20:.1f} MB"


class UploadLimit:
    """Refuse uploads on every connection of ``server`` as soon as they break the limit.

    Use :meth:`install` / :meth:`of` (one per server) rather than the constructor.

    Args:
        server: the viser server.
        max_bytes: the largest file accepted.
        max_in_flight: transfers that may stream at once, all tabs together.
    """

    def __init__(self, server: viser.ViserServer, max_bytes: int = MAX_UPLOAD_BYTES,
                 max_in_flight: int = MAX_IN_FLIGHT) -> None:
        self.server = server
        self.max_bytes = int(max_bytes)
        self.max_in_flight = int(max_in_flight)
        self._buttons: dict[str, Refused] = {}
        self._inflight: dict[str, _Transfer] = {}
        self._lock = threading.Lock()
        self._closed = False
        self._registered: list[tuple[Any, Any, Any]] = []  # (interface, message, handler)
        # the server's GUI (elements shown to every tab): its handlers are on the server's
        # websocket interface, registered by viser before this one
        gui = server.gui
        self._register(gui._websock_interface, gui._current_file_upload_states)
        # each tab's GUI: viser makes its ClientHandle (whose GUI registers its handlers
        # on the connection) in its own connect callback, which runs before this one
        server._websock_server.on_client_connect(self._on_connect)
        for client in server.get_clients().values():     # connected before this
            self._register(client._websock_connection, client.gui._current_file_upload_states)

    @classmethod
    def install(cls, server: viser.ViserServer, max_bytes: int = MAX_UPLOAD_BYTES,
                max_in_flight: int = MAX_IN_FLIGHT) -> UploadLimit:
        """The limit of ``server``, made on the first call (later calls return it)."""
        with _LIMITS_LOCK:
            limit = _LIMITS.get(server)
            if limit is None:
                limit = _LIMITS[server] = cls(server, max_bytes, max_in_flight)
            return limit

    of = install

    def _register(self, interface: Any, states: dict[str, Any]) -> None:
        def on_start(client_id: Any, message: FileTransferStartUpload) -> None:
            self._on_start(client_id, message, states)

        def on_part(client_id: Any, message: FileTransferPart) -> None:
            self._on_part(message)

        for message, handler in ((FileTransferStartUpload, on_start),
                                 (FileTransferPart, on_part)):
            interface.register_handler(message, handler)
            self._registered.append((interface, message, handler))

    async def _on_connect(self, conn: Any) -> None:
        if self._closed:
            return

        def states() -> dict[str, Any] | None:
            client = self.server._connected_clients.get(conn.client_id)
            return None if client is None else client.gui._current_file_upload_states

        # the tab's ClientHandle is registered with the server only once it reports its
        # camera; until then its GUI has no elements, so viser buffers nothing for it
        def on_start(client_id: Any, message: FileTransferStartUpload) -> None:
            s = states()
            if s is not None:
                self._on_start(client_id, message, s)

        def on_part(client_id: Any, message: FileTransferPart) -> None:
            self._on_part(message)

        conn.register_handler(FileTransferStartUpload, on_start)
        conn.register_handler(FileTransferPart, on_part)

    def watch(self, button: viser.GuiUploadButtonHandle, on_refused: Refused) -> None:
        """Accept uploads to ``button`` within the limit; ``on_refused`` is told (on the
        event loop) of each one refused."""
        with self._lock:
            self._buttons[button._impl.uuid] = on_refused

    def unwatch(self, button: viser.GuiUploadButtonHandle) -> None:
        """Refuse every upload to ``button`` from now on (its page is gone)."""
        with self._lock:
            self._buttons.pop(button._impl.uuid, None)

    def in_flight(self) -> int:
        """Transfers streaming now (all tabs)."""
        with self._lock:
            self._forget_finished()
            return len(self._inflight)

    def close(self) -> None:
        """Remove the handlers (a second call does nothing)."""
        if self._closed:
            return
        self._closed = True
        for interface, message, handler in self._registered:
            try:
                interface.unregister_handler(message, handler)
            except (AssertionError, ValueError, KeyError):
                pass
        with _LIMITS_LOCK:
            if _LIMITS.get(self.server) is self:
                del _LIMITS[self.server]

    # handlers (event loop, after viser's own)
    def _forget_finished(self) -> None:
        for uid in [u for u, t in self._inflight.items() if u not in t.states]:
            del self._inflight[uid]      # delivered, dropped, or its client went away

    def _on_start(self, client_id: Any, message: FileTransferStartUpload,
                  states: dict[str, Any]) -> None:
        if self._closed or message.transfer_uuid not in states:
            return                       # not buffered by this GUI: nothing to limit
        name = str(message.filename)[:200]
        t = _Transfer(int(client_id), str(message.source_component_uuid), name,
                      message.size_bytes if isinstance(message.size_bytes, int) else -1,
                      states)
        parts = message.part_count if isinstance(message.part_count, int) else -1
        with self._lock:
            watched = t.button in self._buttons
            self._forget_finished()
            busy = len(self._inflight) >= self.max_in_flight
        if not watched:
            # viser buffers a transfer naming any input element (a slider, a text
            # field...), not only upload buttons: naseview has no other upload
            states.pop(message.transfer_uuid, None)
            self._release(message.transfer_uuid, t)
            log.warning("naseview: upload to an element that takes no upload refused "
                        "(client %s)", t.client_id)
            return
        if not 0 <= t.declared or not 0 <= parts <= max(t.declared, 1):
            self._refuse(message.transfer_uuid, t, f"{name}: the upload announced "
                         "an impossible size; choose the photo again")
        elif t.declared > self.max_bytes:
            self._refuse(message.transfer_uuid, t, upload_too_large(name, t.declared))
        elif busy:
            self._refuse(message.transfer_uuid, t, (
                f"{name}: {self.max_in_flight} uploads are already in progress; wait "
                "until they finish, then choose the photo again"))
        else:
            with self._lock:
                self._inflight[message.transfer_uuid] = t

    def _on_part(self, message: FileTransferPart) -> None:
        with self._lock:
            t = self._inflight.get(message.transfer_uuid)
        if t is None:
            return
        state = t.states.get(message.transfer_uuid)
        if state is None:                      # complete (viser delivered it) or dropped
            with self._lock:
                self._inflight.pop(message.transfer_uuid, None)
            return
        received = int(state.get("transferred_bytes", 0))
        if received > self.max_bytes:
            self._refuse(message.transfer_uuid, t, upload_too_large(t.filename, received))
        elif received > t.declared:
            self._refuse(message.transfer_uuid, t, (
                f"{t.filename}: the upload sent more than the {_mb(t.declared)} it "
                "announced; choose the photo again"))

    def _release(self, transfer_uuid: str, t: _Transfer) -> viser.ClientHandle | None:
        """Acknowledge the transfer as complete, so the browser's button is usable."""
        client = self.server.get_clients().get(t.client_id)
        if client is not None:
            done = max(t.declared, 0)
            client._websock_connection.queue_message(FileTransferPartAck(
                source_component_uuid=t.button, transfer_uuid=transfer_uuid,
                transferred_bytes=done, total_bytes=done))
        return client

    def _refuse(self, transfer_uuid: str, t: _Transfer, why: str) -> None:
        """Drop viser's buffer of the transfer, release the browser's button, tell."""
        t.states.pop(transfer_uuid, None)
        with self._lock:
            self._inflight.pop(transfer_uuid, None)
            on_refused = self._buttons.get(t.button)
        client = self._release(transfer_uuid, t)
        log.info("naseview: upload refused: %s", why)
        if on_refused is None:
            return
        try:
            on_refused(client, why)
        except Exception:
            log.exception("naseview: upload refusal handler failed")


__all__ = ["MAX_IN_FLIGHT", "Refused", "UploadLimit"]
