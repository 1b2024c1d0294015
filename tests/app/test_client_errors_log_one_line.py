"""issue 26 item 12: a client's mistake is one log line, never a traceback: hostile
websocket messages (a wrong value for a slider, an unknown field, a message type viser
does not know) and a typed manoeuvre value outside its range. A traceback means a bug."""

from __future__ import annotations

import logging
import time
from typing import Any
from unittest.mock import MagicMock

import pytest
import viser
from helpers import wait_for

from naseview.app.guard import guarded_viser_server
from naseview.app.headless_tab import HeadlessTab
from naseview.app.panels import Panels
from naseview.errors import NaseviewError


def _send(tab: HeadlessTab, **message: Any) -> None:
    tab.send(**message)


class _Records(logging.Handler):
    def __init__(self) -> None:
        super().__init__(logging.DEBUG)
        self.records: list[logging.LogRecord] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.records.append(record)


@pytest.fixture()
def logged():
    """Every log record of every logger (asyncio and websockets included)."""
    handler = _Records()
    root = logging.getLogger()
    old = root.level
    root.addHandler(handler)
    root.setLevel(logging.DEBUG)
    try:
        yield handler.records
    finally:
        root.removeHandler(handler)
        root.setLevel(old)


def _tracebacks(records: list[logging.LogRecord]) -> list[str]:
    return [r.getMessage() for r in records if r.exc_info or r.exc_text]


def test_hostile_websocket_messages_log_one_line_each(logged) -> None:
    server = guarded_viser_server("127.0.0.1", 0, verbose=False)
    try:
        slider = server.gui.add_slider("s", 0.0, 1.0, 0.1, 0.5)
        u = slider._impl.uuid
        ws = HeadlessTab(server)
        bad = [dict(type="GuiUpdateMessage", uuid=u, updates={"value": "abc"}),
               dict(type="GuiUpdateMessage", uuid=u, updates={"no_such_field": 1}),
               dict(type="GuiUpdateMessage", uuid=u, updates=5)]
        for m in bad:
            _send(ws, **m)
        wait_for(lambda: sum("refused a GuiUpdateMessage" in r.getMessage()
                             for r in logged) >= len(bad), 10, "the three refusals")
        _send(ws, type="NoSuchMessage")                   # closes this connection
        wait_for(lambda: any("not viser's" in r.getMessage() for r in logged), 10,
                 "the undecodable message logged")
        time.sleep(0.2)
        assert _tracebacks(logged) == []
        lines = [r.getMessage() for r in logged if r.levelno >= logging.WARNING]
        assert all("\n" not in line for line in lines), lines
        ws2 = HeadlessTab(server)                            # the server is still up
        ws2.close()
        ws.close()
    finally:
        server.stop()


def test_manoeuvre_value_outside_its_range_is_one_line(logged) -> None:
    server = guarded_viser_server("127.0.0.1", 0, verbose=False)
    try:
        app = MagicMock()
        app.set_manoeuvre.side_effect = NaseviewError(
            "manoeuvre: key 'tip_rotation': 99 is outside [-10, 10]")
        panels = Panels(server, app)
        _name, slider = next(iter(panels.manoeuvres.items()))
        for cb in slider._impl.update_cb:                 # the value typed in a tab
            cb(viser.GuiEvent(client=MagicMock(), client_id=1, target=slider))
        assert panels.error.visible and "99 is outside" in str(panels.error.content)
        assert _tracebacks(logged) == []
        assert any("99 is outside" in r.getMessage() for r in logged)
    finally:
        server.stop()


def test_a_bug_in_an_action_still_logs_its_traceback(logged) -> None:
    server = guarded_viser_server("127.0.0.1", 0, verbose=False)
    try:
        app = MagicMock()
        app.set_manoeuvre.side_effect = ZeroDivisionError("a bug")
        panels = Panels(server, app)
        _name, slider = next(iter(panels.manoeuvres.items()))
        for cb in slider._impl.update_cb:
            cb(viser.GuiEvent(client=MagicMock(), client_id=1, target=slider))
        assert _tracebacks(logged) == ["naseview: action failed"]
    finally:
        server.stop()
