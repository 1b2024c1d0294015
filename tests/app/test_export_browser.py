"""Exports a surgeon downloads from the page open right in other tools (issue 14, item 5):
the GLB is in metres as glTF says (a face ~0.15 m wide, not 150 m), the textured GLB
carries the patient's skin, and the watertight STL can be printed as it is."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest
import trimesh
from helpers import CHROMIUM, CHROMIUM_FLAGS, browser_or_skip, wait_for

pytestmark = pytest.mark.browser


def _download(page, button: str, out: Path) -> bytes:  # type: ignore[no-untyped-def]
    with page.expect_download(timeout=60_000) as info:
        page.get_by_role("button", name=button).click()
    target = out / info.value.suggested_filename
    info.value.save_as(target)
    return target.read_bytes()


def test_downloads_from_the_page_open_right(served, tmp_path: Path):
    browser_or_skip()
    from playwright import sync_api
    server, app = served
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, headless=True,
                                    args=CHROMIUM_FLAGS)
        try:
            page = browser.new_page(viewport={"width": 1100, "height": 900},
                                    accept_downloads=True)
            page.goto(f"http://127.0.0.1:{server.get_port()}/")
            page.wait_for_selector("canvas", timeout=30_000)
            wait_for(lambda: any(s.shown.is_set() for s in app.screens.values()), 60,
                     "the tab's screen")
            page.get_by_text("Export", exact=True).click()        # open the folder
            glb = _download(page, "Mesh .glb", tmp_path)
            mesh = trimesh.load(io.BytesIO(glb), file_type="glb", force="mesh",
                                process=False)
            width = float(np.ptp(mesh.vertices[:, 0]))
            assert 0.08 < width < 0.4, width                        # metres: a face
            data = _download(page, "Face with photo texture .glb", tmp_path)
            skinned = trimesh.load(io.BytesIO(data), file_type="glb", force="mesh",
                                   process=False)
            assert 0.08 < float(np.ptp(skinned.vertices[:, 0])) < 0.4
            assert getattr(skinned.visual, "uv", None) is not None     # the skin travels
            data = _download(page, "Watertight solid .stl (3D print)", tmp_path)
            stl = trimesh.load(io.BytesIO(data), file_type="stl")
            assert stl.is_watertight and stl.volume > 0
        finally:
            browser.close()
