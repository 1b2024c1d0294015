"""End-to-end: the app in headless Chromium (Playwright, the system's /usr/bin/chromium).

The page loads, the face is visible in a screenshot (pixel variance where the nose
projects), and a landmark dragged with real mouse events changes the mesh on the server.
Skipped when Playwright or Chromium is missing; run with ``-m browser``.
"""

from __future__ import annotations

import time
from pathlib import Path

import cv2
import numpy as np
import pytest
from helpers import (
    CHROMIUM,
    CHROMIUM_FLAGS,
    browser_or_skip,
    project_to_view,
    wait_for,
    wait_for_placed_camera,
)

pytestmark = pytest.mark.browser



@pytest.fixture(scope="module")
def app_server(ict_served):
    return ict_served


def test_page_renders_face_and_drag_deforms_mesh(app_server, tmp_path: Path):
    browser_or_skip()
    from playwright import sync_api  # after the check: a missing package fails in CI
    server, app = app_server
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=CHROMIUM_FLAGS)
        try:
            page = browser.new_page(viewport={"width": 820, "height": 540})
            page.goto(f"http://127.0.0.1:{server.get_port()}/")
            page.wait_for_selector("canvas", timeout=30_000)
            wait_for(lambda: any(c.camera.image_width > 0 and c.camera.fov > 0
                                 for c in server.get_clients().values()), 30, "a client camera")
            client = next(iter(server.get_clients().values()))
            wait_for(lambda: app.screen_of(client) is not None
                     and app.screen_of(client).shown.is_set(), 30, "the tab's screen")
            scene = app.screen_of(client).scene
            # the app points the tab's camera at the nose; wait until applied
            wait_for_placed_camera(client, app.controller.baseline)
            canvas = page.locator("canvas").first
            box = canvas.bounding_box()
            assert box is not None
            shot = tmp_path / "page.png"
            cam = client.camera
            sx = box["width"] / cam.image_width
            sy = box["height"] / cam.image_height
            base = app.controller.baseline
            uv = project_to_view(cam, base.V[base.nose_ids].mean(0))
            cx, cy = int(box["x"] + uv[0] * sx), int(box["y"] + uv[1] * sy)

            def crops() -> tuple[np.ndarray, np.ndarray]:
                """(nose area, top-left corner) of a fresh screenshot."""
                page.screenshot(path=str(shot))
                img = cv2.imread(str(shot))
                return (img[max(0, cy - 60):cy + 60, max(0, cx - 60):cx + 60].astype(float),
                        img[5:40, 5:40].astype(float))

            def face_drawn() -> bool:
                crop, corner = crops()
                return bool(crop.size and crop.std() > 6.0
                            and (abs(crop.mean() - corner.mean()) > 5.0 or crop.std() > 15.0))

            # software WebGL draws the face a moment after the camera is set: wait for it
            end = time.monotonic() + 20.0
            while not face_drawn() and time.monotonic() < end:
                time.sleep(0.5)
            crop, corner = crops()
            assert crop.size and crop.std() > 6.0, "the mesh area is blank"
            assert abs(crop.mean() - corner.mean()) > 5.0 or crop.std() > 15.0

            # drag prn upwards with real mouse events
            prn = app.controller.landmarks["prn"]
            uv = project_to_view(cam, prn)
            x0, y0 = box["x"] + uv[0] * sx, box["y"] + uv[1] * sy
            V0 = np.asarray(scene.nose.vertices).copy()
            page.mouse.move(x0, y0)
            page.mouse.down()
            for i in range(1, 5):          # each move waits for a (software) frame
                page.mouse.move(x0, y0 - 9.0 * i)
            page.mouse.up()
            ctl = app.controller
            wait_for(lambda: ctl.history_length >= 2, 20, "the drag to reach the server")
            assert ctl.wait_idle(20)
            moved = {k for k, v in ctl.landmarks.items()
                     if not np.array_equal(v, base.landmarks[k])}
            assert moved, "no landmark moved"
            lid = moved.pop()
            assert ctl.landmarks[lid][1] > base.landmarks[lid][1] + 0.5   # dragged up
            V1 = np.asarray(scene.nose.vertices)
            assert np.abs(V1 - V0).max() > 0.5                          # mesh changed
            assert np.abs(ctl.simulation.V - base.V).max() > 0.5
        finally:
            browser.close()
