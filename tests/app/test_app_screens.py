"""Per-tab screens (issue 14, item 1) with a real viser server and headless tabs (no
browser): each tab has its own panels, scene and patient mode; all of them show the one
simulation of the patient; a tab that goes releases everything it held; the patient
screen opens in patient mode and follows the edits. Also item 6: ``serve --new`` opens no
case, and ``serve`` opens the browser unless ``--no-browser``."""

from __future__ import annotations

import re
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from helpers import drag, naseview_serve, open_tab, wait_for

from naseview.app.gui_value import set_value
from naseview.app.screen import PATIENT_SCREEN_PATH
from naseview.app.serve import start_app


@pytest.fixture()
def served(ict_app):
    """(server, app, tabs): see ``ict_app`` in conftest."""
    return ict_app


def nose(screen) -> np.ndarray:
    return np.asarray(screen.scene.nose.vertices, dtype=np.float64)


def test_two_tabs_have_their_own_view_and_one_simulation(served, baseline):
    server, app, tabs = served
    tab_a, a = open_tab(server, app)
    tab_b, b = open_tab(server, app)
    tabs += [tab_a, tab_b]
    assert a is not b and a.scene is not b.scene and a.panels is not b.panels
    assert a.scene.scope is tab_a.client and b.scene.scope is tab_b.client

    # a display toggle in tab A is A's only
    set_value(a.panels.show_curves, False)
    assert not any(h.visible for h in a.scene.curves.values())
    assert all(h.visible for h in b.scene.curves.values())
    assert b.panels.show_curves.value

    # an edit shows in both tabs; Undo from tab B undoes the patient's simulation
    ctl = app.controller
    drag(ctl, "prn", np.array([0.0, 2.0, 1.0]))
    assert ctl.wait_idle(10)
    base = baseline.V[a.scene.nose_ids]
    assert np.abs(nose(a) - base).max() > 0.5
    np.testing.assert_allclose(nose(b), nose(a))
    assert not a.panels.undo.disabled and not b.panels.undo.disabled
    b.panels.undo.disabled = True                   # B's button state is refreshed below
    b.undo()
    assert ctl.wait_idle(10)
    wait_for(lambda: np.abs(nose(a) - base).max() < 1e-4, 10, "tab A to show the undo")
    assert np.abs(nose(b) - base).max() < 1e-4
    assert a.panels.undo.disabled and not a.panels.redo.disabled
    assert not b.panels.redo.disabled

    # symmetric mode is the patient's: tab B's checkbox follows tab A's
    a.set_symmetric(True)
    assert ctl.symmetric and b.panels.symmetric.value


def test_patient_mode_in_one_tab_leaves_the_other_alone(served):
    server, app, tabs = served
    tab_a, a = open_tab(server, app)
    tab_b, b = open_tab(server, app)
    tabs += [tab_a, tab_b]
    a.patient.enter()
    assert a.patient.active and a.patient.panel.visible
    assert not a.scene.spheres.visible                     # technical overlays hidden in A
    assert a.patient._thread is not None and a.patient._thread.is_alive()
    assert not b.patient.active and not b.patient.panel.visible
    assert b.scene.spheres.visible                         # ...and still shown in B
    look_b = np.asarray(tab_b.client.camera.look_at).copy()
    b_pos = np.asarray(tab_b.client.camera.position).copy()
    # the turntable drives A's camera only: B's server-side camera state never moves
    time.sleep(0.3)
    np.testing.assert_array_equal(np.asarray(tab_b.client.camera.position), b_pos)
    np.testing.assert_array_equal(np.asarray(tab_b.client.camera.look_at), look_b)
    a.patient.exit()
    assert not a.patient.active and a.patient._thread is None


def test_a_closed_tab_releases_its_listeners_and_turntable(served):
    server, app, tabs = served
    ctl = app.controller
    n_sim, n_hist, n_lms = (len(ctl.on_simulation), len(ctl.on_history),
                            len(ctl.on_landmarks))
    tab, screen = open_tab(server, app)
    assert len(ctl.on_simulation) == n_sim + 2     # its scene and its panel
    assert len(ctl.on_history) == n_hist + 1 and len(ctl.on_landmarks) == n_lms + 1
    screen.patient.enter()
    turntable = screen.patient._thread
    assert turntable is not None and turntable.is_alive()
    screen.show_new_patient()                      # its page's worker threads
    page = screen.annotate
    assert page is not None and page._worker.is_alive()
    tab.close()
    assert screen.released.wait(10), "the closed tab was not released"
    assert app.screen_of(tab.client) is None and screen.closed
    assert (len(ctl.on_simulation), len(ctl.on_history), len(ctl.on_landmarks)) == (
        n_sim, n_hist, n_lms)
    turntable.join(5)
    assert not turntable.is_alive()
    page._worker.join(5)
    assert not page._worker.is_alive()
    # edits after the tab went: no error anywhere, the other tabs still follow
    tab2, other = open_tab(server, app)
    tabs.append(tab2)
    drag(ctl, "al_l", np.array([1.0, 0.0, 0.0]))
    assert ctl.wait_idle(10)
    assert ctl.error is None and not other.panels.error.visible


def test_a_reload_is_a_new_tab_with_fresh_defaults(served):
    server, app, tabs = served
    tab, screen = open_tab(server, app)
    set_value(screen.panels.show_curves, False)
    set_value(screen.panels.photo_view, "left")
    tab.close()
    tab2, again = open_tab(server, app)
    tabs.append(tab2)
    assert again is not screen
    assert again.panels.show_curves.value and again.panels.photo_view.value == "front"


def test_the_patient_screen_follows_the_surgeons_edits(served, baseline):
    server, app, tabs = served
    tab_s, surgeon = open_tab(server, app)
    tab_p, patient = open_tab(server, app, path=PATIENT_SCREEN_PATH)
    tabs += [tab_s, tab_p]
    assert patient.patient_screen and patient.patient.active
    assert not surgeon.patient_screen and not surgeon.patient.active
    assert "patient" in surgeon.patient_link.content     # the link that opens it
    table0 = patient.patient.table.content
    drag(app.controller, "prn", np.array([0.0, 0.0, 3.0]))
    assert app.controller.wait_idle(10)
    wait_for(lambda: patient.patient.table.content != table0, 10,
             "the patient screen's measurements to follow")
    assert "→" in patient.patient.table.content
    np.testing.assert_allclose(nose(patient), nose(surgeon))
    assert np.abs(nose(patient) - baseline.V[patient.scene.nose_ids]).max() > 0.5
    patient.patient.set_blend(0.0)                       # the patient's slider: theirs only
    np.testing.assert_allclose(nose(patient), baseline.V[patient.scene.nose_ids], atol=1e-4)
    assert np.abs(nose(surgeon) - baseline.V[surgeon.scene.nose_ids]).max() > 0.5


def test_serve_new_opens_no_case_and_its_tabs_start_on_the_new_patient_page(
        tmp_path, monkeypatch):
    monkeypatch.setenv("NASEVIEW_WORK_DIR", str(tmp_path / "work"))
    server, app = start_app(None, port=0, model="generic", new_patient=True)
    try:
        assert app.controller is None and app.case is None and app.source is None
        assert not app.wait_ready(0.1)                    # no job was ever started
        tab, screen = open_tab(server, app)
        try:
            wait_for(lambda: screen.annotate is not None and screen.annotate.active, 10,
                     "the new-patient page")
            assert screen.annotate.session is not None
            tab2, other = open_tab(server, app)
            try:                                           # another tab: its own patient
                wait_for(lambda: other.annotate is not None and other.annotate.session
                         is not None, 10, "the second tab's page")
                assert other.annotate.session.folder != screen.annotate.session.folder
                assert other.annotate.panel is not screen.annotate.panel
            finally:
                tab2.close()
        finally:
            tab.close()
        assert app.controller is None                      # still nothing reconstructed
    finally:
        app.close()
        server.stop()


def serve_output(args: list[str], tmp_path: Path) -> tuple[str, Path]:
    """Run ``naseview serve ARGS --port 0`` with a recording ``$BROWSER`` until it is
    ready, stop it with Ctrl-C; returns (its output, the file the browser would write)."""
    record = tmp_path / "browser.txt"
    opener = tmp_path / "browser.py"
    opener.write_text("import sys, pathlib\n"
                      f"pathlib.Path({str(record)!r}).write_text(sys.argv[1])\n")
    env = {"NASEVIEW_WORK_DIR": str(tmp_path / "w"),
           "BROWSER": f"{sys.executable} {opener} %s"}
    with naseview_serve(["--port", "0", "--model", "generic", *args], env) as lines:
        if "--no-browser" not in args:
            wait_for(record.exists, 20, "the browser to be opened")
    return "".join(lines), record


def test_serve_opens_the_browser_on_its_address_unless_no_browser(tmp_path):
    out, record = serve_output(["--new"], tmp_path)
    found = re.search(r"serving the new-patient page at (http://127\.0\.0\.1:\d+/)", out)
    assert found, out
    assert record.read_text() == found.group(1)
    record.unlink()
    out, record = serve_output(["--new", "--no-browser"], tmp_path)
    assert "serving the new-patient page at http://127.0.0.1:" in out
    assert not record.exists()
