"""Uploads are limited while they stream (issue 12, finding 6, the upload side).

A raw websocket client speaks viser's upload protocol to the new-patient page's photo
buttons exactly as viser's browser client does (``FileTransferStartUpload``, then 512 KiB
``FileTransferPart`` messages sent without waiting): an upload declaring more than
``MAX_UPLOAD_BYTES`` is dropped at its first message, one that sends more than it
declared is dropped at the part that crosses the line, so the server never holds the
file; the page says why in one line and the browser's button is released. A photo within
the limit still arrives, and a decompression bomb is refused by the pixel check.
"""

from __future__ import annotations

import html
import re
import socket
import time
import uuid
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import msgspec
import numpy as np
import pytest
import viser
import websockets.sync.client
import zstandard
from helpers import bomb_png, png_bytes, wait_for

from naseview.app.annotate_page import AnnotatePage
from naseview.app.guard import guarded_viser_server
from naseview.intake.photos import MAX_UPLOAD_BYTES

PART = 512 * 1024                              # the part size of viser's browser client


@pytest.fixture()
def page(tmp_path: Path) -> Iterator[AnnotatePage]:
    server = guarded_viser_server("127.0.0.1", 0, verbose=False)
    page = AnnotatePage(server, None, work_dir=tmp_path / "work", diagram_model="generic")
    page.start("p1")
    try:
        yield page
    finally:
        page.wait_idle(10)
        page.close()
        server.stop()


@pytest.fixture()
def ws(page: AnnotatePage) -> Iterator[websockets.sync.client.ClientConnection]:
    port = page.server.get_port()
    sock = socket.create_connection(("127.0.0.1", port), timeout=10)
    conn = websockets.sync.client.connect(
        f"ws://127.0.0.1:{port}/", sock=sock, origin=f"http://127.0.0.1:{port}",
        subprotocols=[f"viser-v{viser.__version__}"],  # type: ignore[list-item]
        proxy=None, open_timeout=10, max_size=None, compression=None)
    # viser counts a client as connected once it reports its camera, as the page does
    send(conn, type="ViewerCameraMessage", wxyz=(1.0, 0.0, 0.0, 0.0),
         position=(0.0, 0.0, 5.0), fov=1.0, near=0.1, far=100.0, image_height=600,
         image_width=800, look_at=(0.0, 0.0, 0.0), up_direction=(0.0, 1.0, 0.0))
    wait_for(lambda: page.server.get_clients(), 10, "the client to connect")
    try:
        yield conn
    finally:
        conn.close()


def send(ws: websockets.sync.client.ClientConnection, **message: Any) -> None:
    ws.send(msgspec.msgpack.encode(message))


def start(ws, button: str, name: str, size: int, parts: int) -> str:
    transfer = str(uuid.uuid4())
    send(ws, type="FileTransferStartUpload", source_component_uuid=button,
         transfer_uuid=transfer, filename=name, mime_type="image/jpeg", part_count=parts,
         size_bytes=size)
    return transfer


def part(ws, button: str, transfer: str, index: int, content: bytes) -> None:
    send(ws, type="FileTransferPart", source_component_uuid=button, transfer_uuid=transfer,
         part_index=index, content=content)


def received(frame: bytes) -> list[dict[str, Any]]:
    """The messages of one server frame (viser: two little-endian sizes, then zstd
    compressed msgpack ``{"messages": [...]}``, then binary buffers)."""
    n = int.from_bytes(frame[8:16], "little")
    inner = zstandard.ZstdDecompressor().decompress(
        frame[16:16 + n], max_output_size=int.from_bytes(frame[:8], "little"))
    return list(msgspec.msgpack.decode(inner)["messages"])


def acks(ws, transfer: str, seconds: float = 3.0) -> list[dict[str, Any]]:
    """The ``FileTransferPartAck`` messages for ``transfer`` received within ``seconds``,
    up to the one that completes it."""
    out = []
    try:
        while True:
            for m in received(ws.recv(timeout=seconds)):
                if m.get("type") == "FileTransferPartAck" and m["transfer_uuid"] == transfer:
                    out.append(m)
                    if m["transferred_bytes"] >= m["total_bytes"]:
                        return out
    except TimeoutError:
        return out


def buffered(page: AnnotatePage) -> int:
    """Bytes viser holds for uploads in flight."""
    states = page.server.gui._current_file_upload_states
    return sum(len(p) for s in states.values() for p in s["parts"].values())


def error_markdown(page: AnnotatePage) -> str:
    """The markdown of the page's red error line ("" when hidden)."""
    page.wait_idle(10)
    return str(page.error.content) if page.error.visible else ""


def error_line(page: AnnotatePage) -> str:
    """The text the error line shows (markdown escapes undone)."""
    return html.unescape(re.sub(r"\\(.)", r"\1", error_markdown(page)))


def test_an_upload_declared_too_large_is_dropped_at_its_first_message(page, ws):
    button = page.uploads["front"]._impl.uuid
    size = MAX_UPLOAD_BYTES + 5 * 2**20
    n = -(-size // PART)
    t = start(ws, button, "front.jpg", size, n)
    chunk = b"\xff" * PART
    for i in range(8):                          # the browser keeps sending: nothing is kept
        part(ws, button, t, i, chunk)
    done = acks(ws, t)
    assert done and done[-1]["transferred_bytes"] == done[-1]["total_bytes"]  # released
    wait_for(lambda: "too large" in error_line(page), 10, "the message in the page")
    assert f"front.jpg: {size / 2**20:.1f} MB is too large (limit 60 MB)" in error_line(page)
    assert t not in page.server.gui._current_file_upload_states and buffered(page) == 0
    assert "front" not in page.session.photos


def test_an_upload_sending_more_than_it_declared_is_dropped_as_it_streams(page, ws):
    button = page.uploads["bottom"]._impl.uuid
    t = start(ws, button, "bottom.jpg", 2 * PART, 2)      # declares 1 MiB...
    for i in range(2):
        part(ws, button, t, i if i == 0 else 5, b"\x01" * (3 * PART))  # ...sends more
    wait_for(lambda: "more than" in error_line(page), 10, "the message in the page")
    assert ("bottom.jpg: the upload sent more than the 1.0 MB it announced; choose the "
            "photo again") in error_line(page)            # not "1.5 MB is too large"
    assert t not in page.server.gui._current_file_upload_states and buffered(page) == 0
    assert "bottom" not in page.session.photos


def test_uploads_in_parallel_are_bounded(page, ws):
    buttons = [page.uploads[v]._impl.uuid for v in ("front", "bottom", "left", "right")]
    started = [start(ws, b, f"{k}.jpg", 40 * 2**20, 80) for k, b in enumerate(buttons)]
    extra = start(ws, buttons[0], "again.jpg", 40 * 2**20, 80)   # a fifth one at once
    wait_for(lambda: "again.jpg" in error_line(page), 10, "the fifth upload refused")
    assert "again.jpg: 4 uploads are already in progress" in error_line(page)
    assert "too large" not in error_line(page)            # 40 MB is within the limit
    states = page.server.gui._current_file_upload_states
    assert extra not in states and all(t in states for t in started)


def test_an_upload_naming_another_element_is_dropped(page, ws):
    other = page.alal._impl.uuid                # a number field, not an upload button
    t = start(ws, other, "x.bin", 2 * PART, 2)
    part(ws, other, t, 0, b"\x02" * PART)
    # the server handles messages in order: once a later refusal shows, these were seen
    start(ws, page.uploads["front"]._impl.uuid, "later.jpg", MAX_UPLOAD_BYTES + 1, 200)
    wait_for(lambda: "later.jpg" in error_line(page), 10, "the later upload refused")
    assert t not in page.server.gui._current_file_upload_states and buffered(page) == 0


def test_a_photo_within_the_limit_arrives(page, ws):
    data = png_bytes(np.full((400, 300, 3), 128, np.uint8))
    button = page.uploads["left"]._impl.uuid
    parts = [data[i:i + PART] for i in range(0, len(data), PART)]
    t = start(ws, button, "left.png", len(data), len(parts))
    for i, c in enumerate(parts):
        part(ws, button, t, i, c)
    end = time.monotonic() + 10.0
    while "left" not in page.session.photos and time.monotonic() < end:
        try:                                   # read what the server sends meanwhile
            ws.recv(timeout=0.2)
        except TimeoutError:
            pass
    assert page.session.photos["left"].width == 300


def test_a_decompression_bomb_upload_is_refused_in_one_line(page, ws):
    data = bomb_png(32000, 32000)
    assert len(data) < 200_000
    button = page.uploads["right"]._impl.uuid
    name = "<img src=x onerror=alert(1)>.png"  # the page's markdown would run raw HTML
    t = start(ws, button, name, len(data), 1)
    part(ws, button, t, 0, data)
    wait_for(lambda: "megapixels" in error_line(page), 10, "the pixel-limit message")
    line = error_line(page)
    assert "32000x32000" in line and "\n" not in line
    assert name in line and "<img" not in error_markdown(page)  # shown, as text only
    assert "right" not in page.session.photos
