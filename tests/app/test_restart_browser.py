"""Closing the tab or restarting the server loses nothing (issue 14, item 2), end to end:
``naseview serve CASE`` in a subprocess (work folder in a tmp dir), a landmark dragged
with real mouse events in headless Chromium, Ctrl-C, the same command again: the page
shows the same mesh (screenshots), Undo is possible and undoes the drag, and the patient
list names the patient."""

from __future__ import annotations

import json
import shutil
import socket
import time
from pathlib import Path

import cv2
import numpy as np
import pytest
from helpers import CHROMIUM, CHROMIUM_FLAGS, browser_or_skip, naseview_serve, wait_for

from naseview.app.naseview_app import demo_case_dir
from naseview.app.screen import nose_view
from naseview.editing.baseline import baseline_from_output_dir

pytestmark = pytest.mark.browser

VIEWPORT = {"width": 720, "height": 480}


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def to_pixel(X: np.ndarray, eye: np.ndarray, target: np.ndarray, fov: float,
             box: dict[str, float]) -> tuple[float, float]:
    """Page pixel of world point ``X`` (mm) seen by a camera at ``eye`` looking at
    ``target`` (+y up, vertical ``fov`` rad) filling the canvas ``box``."""
    fwd = (target - eye) / np.linalg.norm(target - eye)
    right = np.cross(fwd, [0.0, 1.0, 0.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, fwd)
    d = X - eye
    z = float(d @ fwd)
    f = (box["height"] / 2.0) / np.tan(fov / 2.0)
    return (box["x"] + box["width"] / 2.0 + f * float(d @ right) / z,
            box["y"] + box["height"] / 2.0 - f * float(d @ up) / z)


def shot(page, path: Path) -> np.ndarray:
    """A screenshot once the face is drawn (software WebGL takes seconds) and settled."""
    end = time.monotonic() + 90.0
    while True:
        page.screenshot(path=str(path))
        img = cv2.imread(str(path))
        assert img is not None
        box = page.locator("canvas").first.bounding_box()
        w = int(box["width"]) if box else img.shape[1]
        if img[150:, :w].std() > 12.0 or time.monotonic() > end:
            break
        time.sleep(1.0)
    time.sleep(2.0)
    page.screenshot(path=str(path))
    return cv2.imread(str(path)).astype(np.float64)


def open_page(browser, port: int, text: str):
    page = browser.new_page(viewport=VIEWPORT)
    page.goto(f"http://127.0.0.1:{port}/")
    page.wait_for_selector("canvas", timeout=60_000)
    page.get_by_text(text).first.wait_for(timeout=60_000)
    return page


def test_an_edit_survives_a_server_restart_with_its_undo(tmp_path: Path):
    browser_or_skip()
    from playwright import sync_api  # after the check: a missing package fails in CI

    case = shutil.copytree(demo_case_dir(), tmp_path / "cases" / "p7")
    work = tmp_path / "work"
    pid = json.loads((case / "case.json").read_text())["id"]
    sim = work / pid / "simulations" / "simulation-1.json"
    port = free_port()

    def saved_edit() -> dict:
        return json.loads(sim.read_text())["edit"]

    serve = [str(case), "--port", str(port), "--model", "generic", "--no-browser"]
    env = {"NASEVIEW_WORK_DIR": str(work)}
    with naseview_serve(serve, env):                   # stopped with Ctrl-C at the end
        wait_for(sim.is_file, 120, "the reconstruction kept and its simulation started")
        base = baseline_from_output_dir(work / pid / "reconstruction")
        target, eye, fov = nose_view(base)
        first = saved_edit()
        with sync_api.sync_playwright() as p:
            browser = p.chromium.launch(executable_path=CHROMIUM, headless=True,
                                        args=CHROMIUM_FLAGS)
            try:
                page = open_page(browser, port, "Simulation 1")
                before = shot(page, tmp_path / "1-opened.png")
                box = page.locator("canvas").first.bounding_box()
                assert box is not None
                x0, y0 = to_pixel(base.landmarks["prn"], eye, target, fov, box)
                page.mouse.move(x0, y0)
                page.mouse.down()
                for i in range(1, 4):          # each move waits for a software frame
                    page.mouse.move(x0, y0 - 12.0 * i)
                page.mouse.up()
                wait_for(lambda: saved_edit() != first, 60, "the drag autosaved")
                edited = shot(page, tmp_path / "2-dragged.png")
                assert np.abs(edited - before).mean() > 0.05, "the drag changed nothing"
            finally:
                browser.close()
    kept = saved_edit()
    assert kept != first

    with naseview_serve(serve, env):                   # the same command again
        with sync_api.sync_playwright() as p:
            browser = p.chromium.launch(executable_path=CHROMIUM, headless=True,
                                        args=CHROMIUM_FLAGS)
            try:
                page = open_page(browser, port, "Simulation 1")
                reopened = shot(page, tmp_path / "3-restarted.png")
                # the same nose on screen: far closer to the edited page than the first
                # (around the tip, right of the scale bar, whose place follows the edit)
                def nose(img: np.ndarray) -> np.ndarray:
                    x, y = int(x0), int(y0)
                    return img[max(0, y - 120):y + 60, max(0, x - 30):x + 130]

                same, unedited = (np.abs(nose(reopened) - nose(edited)).mean(),
                                  np.abs(nose(reopened) - nose(before)).mean())
                assert same < 0.5 * unedited, (same, unedited)
                assert saved_edit() == kept                  # opening wrote nothing new
                page.get_by_text("All patients").first.click()
                page.get_by_text(pid).first.wait_for(timeout=20_000)
                undo = page.get_by_role("button", name="Undo").first
                assert undo.is_enabled()
                undo.click()
                wait_for(lambda: saved_edit() != kept, 60, "the undo autosaved")
                undone = shot(page, tmp_path / "4-undone.png")
                assert np.abs(nose(undone) - nose(before)).mean() < \
                    np.abs(nose(undone) - nose(edited)).mean()
            finally:
                browser.close()
    undone_edit = saved_edit()
    assert undone_edit["history_index"] == kept["history_index"] - 1
    assert undone_edit["landmarks"] == first["landmarks"]     # back to the reconstruction
