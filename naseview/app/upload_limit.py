"""Upload size limit applied while the file streams in (viser 1.1.1 upload buttons).

How viser delivers a file from ``gui.add_upload_button``: the browser sends one
``FileTransferStartUpload`` message (file name, declared ``size_bytes``, ``part_count``)
and then, without waiting for any answer, ``FileTransferPart`` messages of 512 KiB. viser
keeps every part in ``GuiApi._current_file_upload_states[transfer]`` and joins them only
once all parts are in, then calls ``on_upload`` with the whole file: on its own, an upload
of any size is held entirely in memory before naseview could look at it (viser has no
size option), and nothing bounds a client whose parts exceed what it declared.

:class:`UploadLimit` adds two handlers to the server's websocket interface, which viser
runs right after its own (handlers run in registration order, on the event loop):

- on the start message, a declared size over the limit is refused at once: viser's buffer
  for the transfer is dropped, so every part that follows is discarded as it arrives;
- on each part, the bytes received so far are compared with the declared size and with
  the limit, and the transfer is dropped the moment either is exceeded;
- at most :attr:`UploadLimit.max_in_flight` transfers to the watched buttons stream at
  once (one per photo button is what a user does), so parallel uploads cannot add up;
- a transfer naming any other element is dropped at once: viser accepts one for any input
  element (a hostile client could name a slider and stream without bound), and naseview
  has no upload but the watched buttons.

A refused upload gets a final acknowledgement, so the browser's upload button is usable
again at once, and ``on_refused`` is told (the page shows a one-line message). The memory
held for one upload is at most the limit plus one websocket message.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Protocol

import viser
from viser._messages import FileTransferPart, FileTransferPartAck, FileTransferStartUpload

log = logging.getLogger(__name__)

Refused = Callable[[viser.ClientHandle | None, str, int], None]
"""``on_refused(client, file name, bytes declared or received)``."""


@dataclass
class _Transfer:
    client_id: int
    button: str
    filename: str
    declared: int


class UploadScope(Protocol):
    """What :class:`UploadLimit` needs of a viser scope: its ``gui`` (where the upload
    buttons buffer their transfers) and the tabs it reaches. A ``viser.ViserServer``
    (every tab) is one; :class:`naseview.app.scope.ClientAsServer` (one tab) another."""

    @property
    def gui(self) -> viser.GuiApi: ...

    def get_clients(self) -> Mapping[int, viser.ClientHandle]: ...


class UploadLimit:
    """Refuse uploads to the watched buttons as soon as they exceed ``max_bytes``.

    Args:
        server: the scope the watched buttons live in (the server, or one tab as
            :class:`~naseview.app.scope.ClientAsServer`).
        max_bytes: the largest file accepted.
        on_refused: called (on the event loop) with the client, the file name and the
            size that was refused.
        max_in_flight: transfers to the watched buttons that may stream at once.
    """

    def __init__(self, server: UploadScope, max_bytes: int, on_refused: Refused,
                 max_in_flight: int = 4) -> None:
        self.server = server
        self.max_bytes = int(max_bytes)
        self.max_in_flight = int(max_in_flight)
        self.on_refused = on_refused
        self._buttons: set[str] = set()
        self._inflight: dict[str, _Transfer] = {}
        self._lock = threading.Lock()
        self._closed = False
        # viser keeps the transfers it buffers here and its handlers in the GUI's
        # websocket interface (no public hook exists in viser 1.1.1)
        self._states: dict[str, Any] = server.gui._current_file_upload_states
        self._ws = server.gui._websock_interface
        self._ws.register_handler(FileTransferStartUpload, self._on_start)
        self._ws.register_handler(FileTransferPart, self._on_part)

    def watch(self, button: viser.GuiUploadButtonHandle) -> None:
        """Apply the limit to ``button``."""
        self._buttons.add(button._impl.uuid)

    def close(self) -> None:
        """Stop watching (the handlers are removed; a second call does nothing)."""
        if self._closed:
            return
        self._closed = True
        self._ws.unregister_handler(FileTransferStartUpload, self._on_start)
        self._ws.unregister_handler(FileTransferPart, self._on_part)

    # handlers (event loop, after viser's own)
    def _on_start(self, client_id: Any, message: FileTransferStartUpload) -> None:
        if message.transfer_uuid not in self._states:
            return
        if message.source_component_uuid not in self._buttons:
            # viser buffers a transfer naming any input element (a slider, a text
            # field...), not only upload buttons: naseview has no other upload
            self._states.pop(message.transfer_uuid, None)
            log.warning("naseview: upload to a non-upload element refused")
            return
        t = _Transfer(int(client_id), message.source_component_uuid, str(message.filename),
                      message.size_bytes if isinstance(message.size_bytes, int) else -1)
        parts = message.part_count if isinstance(message.part_count, int) else -1
        if not 0 <= t.declared <= self.max_bytes or not 0 <= parts <= max(t.declared, 1):
            self._refuse(message.transfer_uuid, t, max(t.declared, 0))
            return
        with self._lock:
            for uid in [u for u in self._inflight if u not in self._states]:
                del self._inflight[uid]       # finished, or its client went away
            busy = len(self._inflight) >= self.max_in_flight
            if not busy:
                self._inflight[message.transfer_uuid] = t
        if busy:
            self._refuse(message.transfer_uuid, t, t.declared)

    def _on_part(self, client_id: Any, message: FileTransferPart) -> None:
        with self._lock:
            t = self._inflight.get(message.transfer_uuid)
        if t is None:
            return
        state = self._states.get(message.transfer_uuid)
        if state is None:                      # complete (viser delivered it) or dropped
            with self._lock:
                self._inflight.pop(message.transfer_uuid, None)
            return
        received = int(state.get("transferred_bytes", 0))
        if received > t.declared or received > self.max_bytes:
            self._refuse(message.transfer_uuid, t, received)

    def _refuse(self, transfer_uuid: str, t: _Transfer, nbytes: int) -> None:
        """Drop viser's buffer of the transfer, release the browser's button, tell."""
        self._states.pop(transfer_uuid, None)
        with self._lock:
            self._inflight.pop(transfer_uuid, None)
        client = self.server.get_clients().get(t.client_id)
        if client is not None:
            done = max(t.declared, 0)
            client._websock_connection.queue_message(FileTransferPartAck(
                source_component_uuid=t.button, transfer_uuid=transfer_uuid,
                transferred_bytes=done, total_bytes=done))
        log.info("naseview: upload %r refused (%d bytes)", t.filename, nbytes)
        try:
            self.on_refused(client, t.filename, nbytes)
        except Exception:
            log.exception("naseview: upload refusal handler failed")


__all__ = ["UploadLimit", "UploadScope"]
