"""The surgical plan and the depth handle in the app, with a real viser server and
headless tabs (no browser; the typed manoeuvre in Chromium is test_plan_browser.py).

- a manoeuvre set in one tab moves every tab's slider; Undo puts them back;
- the depth arrow of a selected landmark moves it along the skin's normal only (a
  sideways pull of the arrow does nothing), as one undo entry, from any view.
"""

from __future__ import annotations

import numpy as np
import viser
from helpers import open_tab, wait_for


def test_a_plan_set_in_one_tab_shows_on_every_tab_and_undo_resets_it(ict_app):
    server, app, tabs = ict_app
    tab_a, a = open_tab(server, app)
    tab_b, b = open_tab(server, app)
    tabs += [tab_a, tab_b]
    a.set_manoeuvre("tip_projection", 1.5)
    wait_for(lambda: float(b.panels.manoeuvres["tip_projection"].value) == 1.5, 10,
             "tab B's slider")
    assert not b.panels.clear_plan.disabled
    ctl = app.controller
    assert ctl.wait_idle(10) and ctl.simulation.manoeuvres == {"tip_projection": 1.5}
    b.undo()
    wait_for(lambda: float(a.panels.manoeuvres["tip_projection"].value) == 0.0, 10,
             "tab A's slider after Undo")
    assert ctl.manoeuvres == {} and a.panels.clear_plan.disabled


def test_the_depth_arrow_moves_a_landmark_along_the_normal_only(ict_app, baseline):
    server, app, tabs = ict_app
    tab, screen = open_tab(server, app)
    tabs.append(tab)
    scene, ctl = screen.scene, app.controller
    scene.select("prn")
    depth = scene.depth
    assert depth.landmark == "prn" and depth._handle is not None
    n = depth._normal
    assert abs(np.linalg.norm(n) - 1.0) < 1e-9 and n[2] > 0.5    # the tip's normal: forwards
    start = ctl.landmarks["prn"]
    handle = depth._handle
    origin = np.array(handle.position, np.float64)           # a copy: viser updates in place
    side = np.cross(n, [0.0, 1.0, 0.0])
    side /= np.linalg.norm(side)

    def event(phase: str) -> viser.TransformControlsEvent:
        return viser.TransformControlsEvent(tab.client, tab.client.client_id, handle, phase)

    depth._on_update(event("start"))
    handle.position = origin + 1.5 * n + 2.0 * side      # the browser moves the arrow
    depth._on_update(event("update"))
    handle.position = origin - 0.8 * n + 1.0 * side
    depth._on_update(event("end"))
    np.testing.assert_allclose(ctl.landmarks["prn"], start - 0.8 * n, atol=1e-9)
    assert ctl.history_length == 2                        # one drag, one undo entry
    assert ctl.undo()
    np.testing.assert_array_equal(ctl.landmarks["prn"], baseline.landmarks["prn"])
    # a move the app makes itself (client None) is not the surgeon's
    depth._on_update(viser.TransformControlsEvent(None, None, handle, "start"))
    assert ctl.dragging is None
