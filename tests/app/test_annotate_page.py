"""The new-patient page with a real viser server (no browser): dragging a placed click."""

from __future__ import annotations

import asyncio
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from helpers import png_bytes

from naseview.app.annotate_page import AnnotatePage
from naseview.app.guard import guarded_viser_server


@pytest.fixture()
def page(tmp_path: Path):
    server = guarded_viser_server("127.0.0.1", 0, verbose=False)
    page = AnnotatePage(server, None, work_dir=tmp_path, diagram_model="generic")
    try:
        yield page
    finally:
        page.close()
        server.stop()


def drag_event(phase: str, start: np.ndarray, end: np.ndarray, client_id: int = 7,
               index: int = 0) -> SimpleNamespace:
    """What viser passes to ``on_drag`` for the ring ``index`` of one client."""
    return SimpleNamespace(phase=phase, instance_index=index, client_id=client_id,
                           start_position=tuple(start), end_position=tuple(end))


def test_a_finished_drag_forgets_the_client_and_moves_the_click_once(page: AnnotatePage):
    session = page.start("p1")
    page.upload("front", png_bytes(np.full((400, 300, 3), 120, np.uint8)))
    assert page.wait_idle(10)
    session.place("front", "g", (100.0, 120.0))        # ring 0 of the front photo
    page.submit(page._redraw)
    assert page.wait_idle(10)
    plane = page.plane
    assert plane is not None
    grab = plane.to_world(np.array([100.0, 120.0]), 0.3)[0]
    to = plane.to_world(np.array([130.0, 150.0]), 0.3)[0]

    asyncio.run(page._on_drag(drag_event("start", grab, grab)))
    asyncio.run(page._on_drag(drag_event("update", grab, to)))
    asyncio.run(page._on_drag(drag_event("end", grab, to)))
    assert page.wait_idle(10)
    np.testing.assert_allclose(session.clicks["front"]["g"], [130.0, 150.0], atol=1e-6)
    assert page._drag == {}                               # the client's drag is over

    # a stray update from that client without a new "start" moves nothing
    rings = np.array(page._handles["clicks"].batched_positions, dtype=np.float64)
    away = plane.to_world(np.array([250.0, 300.0]), 0.3)[0]
    asyncio.run(page._on_drag(drag_event("update", grab, away)))
    np.testing.assert_array_equal(page._handles["clicks"].batched_positions, rings)


def test_an_upload_posts_no_toast_over_the_photo_but_lost_clicks_get_one(
        page: AnnotatePage, monkeypatch: pytest.MonkeyPatch):
    """Toasts stack over the photo where the first landmarks are clicked (on a small
    window): a photo loaded says so in the panel only; replacing one says its clicks went."""
    toasts: list[tuple[str, str]] = []
    monkeypatch.setattr(page, "notify", lambda title, body, *a, **k: toasts.append(
        (title, body)))
    session = page.start("p2")
    page.upload("front", png_bytes(np.full((400, 300, 3), 120, np.uint8)))
    page.upload("bottom", png_bytes(np.full((400, 300, 3), 110, np.uint8)))
    assert page.wait_idle(10)
    assert toasts == []
    session.place("front", "g", (100.0, 120.0))
    page.upload("front", png_bytes(np.full((400, 300, 3), 130, np.uint8)))
    assert page.wait_idle(10)
    assert len(toasts) == 1
    assert "The 1 click on the previous front photo was removed" in toasts[0][1]
    assert session.clicks["front"] == {}
