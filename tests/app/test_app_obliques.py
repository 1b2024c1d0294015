"""Issue 24 item 4: a six-photo case (the two obliques) opens in the app; its photo panel
and "On the photos" offer the obliques, and the photo panel shows one."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from helpers import open_tab, wait_for

from naseview.app.gui_value import set_value
from naseview.app.serve import start_app
from naseview.cli import main as naseview_main
from naseview.landmarks import ALL_VIEWS


@pytest.fixture(scope="module")
def six_served(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Any, Any]]:
    case = tmp_path_factory.mktemp("six") / "case"
    naseview_main(["synth", str(case), "--model", "generic", "--seed", "1", "--noise-px", "1",
                "--views", ",".join(ALL_VIEWS)])
    server, app = start_app(Path(case), host="127.0.0.1", port=0, model="generic")
    assert app.wait_ready(120), "the six-photo case did not open"
    yield server, app
    app.close()
    server.stop()


def test_a_six_photo_case_lists_its_obliques_in_the_photo_panels(six_served):
    server, app = six_served
    assert set(app.case.views) == set(ALL_VIEWS)
    tab, screen = open_tab(server, app)
    try:
        p = screen.panels
        wait_for(lambda: tuple(p.photo_view.options) == ALL_VIEWS, 30, "the oblique options")
        for d in screen.photo_sim.displays:       # the View folder and "On the photos"
            assert tuple(d.view.options) == ALL_VIEWS
        set_value(p.photo_view, "oblique_left")
        screen.show_photo("oblique_left")
        assert p.photo.visible
        assert "oblique_left" in p.residuals.content
        d = screen.photo_sim.displays[-1]
        screen.photo_sim.computed.clear()
        set_value(d.view, "oblique_right")
        screen.photo_sim.request("oblique_right")
        wait_for(lambda: screen.photo_sim.cached("oblique_right") is not None, 60,
                 "the oblique composite")
    finally:
        tab.close()
