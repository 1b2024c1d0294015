"""issue 26 item 4 (and 10): the upload limit holds on every connection of a server,
whatever element a transfer names, with no new-patient page open, and the number of
uploads in flight is bounded for the whole server (all tabs together).

A raw websocket client speaks viser's upload protocol (``FileTransferStartUpload``, then
``FileTransferPart`` messages sent without waiting), as a hostile local client would.
"""

from __future__ import annotations

import threading
import uuid
from collections.abc import Iterator
from typing import Any

import pytest
import viser
from helpers import wait_for

from naseview.app.guard import guarded_viser_server
from naseview.app.headless_tab import HeadlessTab
from naseview.app.upload_limit import MAX_IN_FLIGHT, UploadLimit

PART = 512 * 1024


def send(ws: HeadlessTab, **message: Any) -> None:
    ws.send(**message)


def start(ws, element: str, name: str, size: int, parts: int) -> str:
    transfer = str(uuid.uuid4())
    send(ws, type="FileTransferStartUpload", source_component_uuid=element,
         transfer_uuid=transfer, filename=name, mime_type="image/jpeg", part_count=parts,
         size_bytes=size)
    return transfer


def part(ws, element: str, transfer: str, index: int, content: bytes) -> None:
    send(ws, type="FileTransferPart", source_component_uuid=element, transfer_uuid=transfer,
         part_index=index, content=content)


def buffered(server: viser.ViserServer) -> int:
    """Bytes viser holds for uploads in flight, in the server's GUI and every tab's."""
    guis = [server.gui] + [c.gui for c in server.get_clients().values()]
    return sum(len(p) for g in guis for s in g._current_file_upload_states.values()
               for p in s["parts"].values())


class Viewer:
    """A guarded server whose tabs each get a slider and a photo button of their own (a
    viewer), plus a slider shared by every tab; no new-patient page."""

    def __init__(self) -> None:
        self.server = guarded_viser_server("127.0.0.1", 0, verbose=False)
        self.shared = self.server.gui.add_slider("shared", 0.0, 1.0, 0.1, 0.5)
        self.tabs: dict[int, dict[str, Any]] = {}
        self.refused: list[str] = []
        self.lock = threading.Lock()
        self.server.on_client_connect(self._tab)

    def _tab(self, client: viser.ClientHandle) -> None:
        slider = client.gui.add_slider("tab slider", 0.0, 1.0, 0.1, 0.5)
        button = client.gui.add_upload_button("photo")
        UploadLimit.of(self.server).watch(button, lambda _c, why: self.refused.append(why))
        with self.lock:
            self.tabs[client.client_id] = {"slider": slider._impl.uuid,
                                           "button": button._impl.uuid}

    def tab(self, index: int) -> dict[str, Any]:
        wait_for(lambda: len(self.tabs) > index, 10, "the tab's GUI")
        with self.lock:
            return self.tabs[sorted(self.tabs)[index]]


@pytest.fixture()
def viewer() -> Iterator[Viewer]:
    v = Viewer()
    try:
        yield v
    finally:
        v.server.stop()


def test_a_viewer_tab_slider_takes_no_upload(viewer: Viewer) -> None:
    ws = HeadlessTab(viewer.server)
    try:
        target = viewer.tab(0)["slider"]            # a tab's own GUI element
        t = start(ws, target, "x.bin", 40 * PART, 40)
        for i in range(6):
            part(ws, target, t, i, b"\x01" * PART)
        shared = viewer.shared._impl.uuid            # an element every tab shows
        t2 = start(ws, shared, "y.bin", 40 * PART, 40)
        for i in range(6):
            part(ws, shared, t2, i, b"\x02" * PART)
        # messages are handled in order: once a later refusal shows, those were seen
        start(ws, viewer.tab(0)["button"], "later.jpg", 10**12, 10)
        wait_for(lambda: any("later.jpg" in r for r in viewer.refused), 10, "the refusal")
        assert buffered(viewer.server) == 0
        client = next(iter(viewer.server.get_clients().values()))
        assert not client.gui._current_file_upload_states
        assert not viewer.server.gui._current_file_upload_states
    finally:
        ws.close()


def test_uploads_in_flight_are_bounded_across_tabs(viewer: Viewer) -> None:
    tabs = [HeadlessTab(viewer.server) for _ in range(3)]
    try:
        buttons = [viewer.tab(i)["button"] for i in range(3)]
        started = [start(ws, b, f"t{i}-{k}.jpg", 50 * 2**20, 100)
                   for i, (ws, b) in enumerate(zip(tabs, buttons, strict=True))
                   for k in range(4)]
        wait_for(lambda: len(viewer.refused) >= 12 - MAX_IN_FLIGHT, 10, "the refusals")
        limit = UploadLimit.of(viewer.server)
        assert limit.in_flight() == MAX_IN_FLIGHT
        held = sum(t in c.gui._current_file_upload_states
                   for c in viewer.server.get_clients().values() for t in started)
        assert held == MAX_IN_FLIGHT                  # 4 of 12, not 4 per tab
        assert all("uploads are already in progress" in r and "too large" not in r
                   for r in viewer.refused), viewer.refused
    finally:
        for ws in tabs:
            ws.close()


def test_every_guarded_server_has_the_limit() -> None:
    server = guarded_viser_server("127.0.0.1", 0, verbose=False)
    try:
        assert UploadLimit.of(server) is UploadLimit.of(server)
        assert UploadLimit.of(server).max_in_flight == MAX_IN_FLIGHT
    finally:
        server.stop()
