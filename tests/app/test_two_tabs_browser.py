"""Two browser tabs on one served app (issue 14, item 1), in headless Chromium.

Tab A and tab B open the same page. Orbiting A's view leaves B's camera where it was;
patient mode started in A changes nothing in B's panel; a landmark dragged with real
mouse events in B reshapes the face in both tabs (both clients' nose mesh handles); Undo
clicked in B undoes the patient's simulation and both tabs show it; B's "Open the
patient screen" link opens a third tab in patient mode. Screenshots of both
tabs after the drag are written to the test's tmp folder (A is the patient screen
following B's edit). Skipped without Playwright / Chromium, except under ``CI=true``.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest
from helpers import (
    CHROMIUM,
    CHROMIUM_FLAGS,
    GaussianSolver,
    browser_or_skip,
    ict_baseline,
    project_to_view,
    wait_for,
    wait_for_placed_camera,
)

from naseview.app.guard import guarded_viser_server
from naseview.app.naseview_app import NaseviewApp

pytestmark = pytest.mark.browser


@pytest.fixture(scope="module")
def served():
    def factory(b, params, iters):
        return GaussianSolver(b), ["prn", "c", "al_l", "al_r"], b.nose_ids

    server = guarded_viser_server("127.0.0.1", 0, verbose=False)
    app = NaseviewApp(server, solver_factory=factory)
    base = ict_baseline()
    app.open_baseline(base, case_id="ict-mean")
    assert app.wait_ready(60)
    yield server, app, base
    app.close()
    server.stop()


def test_two_tabs_independent_cameras_one_simulation(served, tmp_path: Path):
    browser_or_skip()
    from playwright import sync_api
    server, app, base = served
    url = f"http://127.0.0.1:{server.get_port()}/"
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, headless=True,
                                    args=CHROMIUM_FLAGS)
        try:
            pages = []
            for _ in range(2):
                page = browser.new_page(viewport={"width": 600, "height": 380})
                page.goto(url)
                page.wait_for_selector("canvas", timeout=30_000)
                pages.append(page)
            wait_for(lambda: len(app.screens) == 2
                     and all(s.shown.is_set() for s in app.screens.values()), 30,
                     "both tabs' screens")
            a, b = sorted(app.screens.values(), key=lambda s: s.client.client_id)
            page_a, page_b = pages
            for s in (a, b):      # each tab's camera on the nose (its own placement)
                wait_for_placed_camera(s.client, base)

            # orbit tab A's view: B's camera stays where it was
            b_pos = np.asarray(b.client.camera.position).copy()
            a_pos = np.asarray(a.client.camera.position).copy()
            page_a.bring_to_front()               # a background tab does not render
            box_a = page_a.locator("canvas").first.bounding_box()
            assert box_a is not None
            x0, y0 = box_a["x"] + 100, box_a["y"] + 0.75 * box_a["height"]  # no sphere there
            page_a.mouse.move(x0, y0)
            page_a.mouse.down()
            for i in range(1, 4):                 # each move waits for a software frame
                page_a.mouse.move(x0 + 40 * i, y0 - 6 * i)
            page_a.mouse.up()
            wait_for(lambda: np.linalg.norm(np.asarray(a.client.camera.position) - a_pos)
                     > 5.0, 15, "tab A's camera to move")
            time.sleep(0.5)
            np.testing.assert_allclose(np.asarray(b.client.camera.position), b_pos,
                                       atol=1e-6)

            # patient mode in tab A: tab B's panel is untouched
            page_a.get_by_role("button", name="Patient mode (presentation)").click()
            wait_for(lambda: a.patient.active, 15, "patient mode in tab A")
            page_a.get_by_text("Before ↔ After").first.wait_for(timeout=15_000)
            assert not b.patient.active and not b.patient.panel.visible
            assert page_b.get_by_text("Before ↔ After").count() == 0
            assert page_b.get_by_role("button", name="Undo").is_visible()

            # drag prn upwards in tab B with real mouse events: both tabs follow
            ctl = app.controller
            page_b.bring_to_front()
            time.sleep(0.5)
            cam_b = b.client.camera
            box_b = page_b.locator("canvas").first.bounding_box()
            assert box_b is not None
            sx, sy = box_b["width"] / cam_b.image_width, box_b["height"] / cam_b.image_height
            uv = project_to_view(cam_b, ctl.landmarks["prn"])
            x0, y0 = box_b["x"] + uv[0] * sx, box_b["y"] + uv[1] * sy
            page_b.mouse.move(x0, y0)
            page_b.mouse.down()
            for i in range(1, 4):
                page_b.mouse.move(x0, y0 - 12.0 * i)
            page_b.mouse.up()
            wait_for(lambda: ctl.history_length >= 2, 20, "the drag to reach the server")
            assert ctl.wait_idle(20)
            base_nose = base.V[a.scene.nose_ids]
            for s in (a, b):
                wait_for(lambda s=s: np.abs(np.asarray(s.scene.nose.vertices)
                                            - base_nose).max() > 0.5, 10,
                         "the edit in both tabs")
            np.testing.assert_allclose(np.asarray(a.scene.nose.vertices),
                                       np.asarray(b.scene.nose.vertices))
            time.sleep(1.0)
            page_b.screenshot(path=str(tmp_path / "tab-b-surgeon.png"))
            page_a.bring_to_front()
            time.sleep(1.5)
            page_a.screenshot(path=str(tmp_path / "tab-a-patient-screen.png"))
            page_b.bring_to_front()

            # Undo clicked in tab B undoes the patient's simulation, in both tabs
            page_b.get_by_role("button", name="Undo").click()
            wait_for(lambda: ctl.history_index == 0, 15, "the undo")
            assert ctl.wait_idle(20)
            for s in (a, b):
                wait_for(lambda s=s: np.abs(np.asarray(s.scene.nose.vertices)
                                            - base_nose).max() < 1e-3, 10,
                         "the undo in both tabs")
            assert a.patient.active                  # tab A is still presenting

            # the surgeon's link opens the patient screen: a tab in patient mode
            with page_b.expect_popup() as popup:
                page_b.get_by_text("Open the patient screen").click()
            page_p = popup.value
            wait_for(lambda: len(app.screens) == 3, 30, "the patient screen to connect")
            ps = max(app.screens.values(), key=lambda s: s.client.client_id)
            wait_for(lambda: ps.shown.is_set() and ps.patient.active, 30,
                     "the patient screen in patient mode")
            assert ps.patient_screen and not b.patient.active
            assert ps.patient.panel.visible and page_p.url.startswith(url)
        finally:
            browser.close()
    print(f"\nscreenshots: {tmp_path}")
