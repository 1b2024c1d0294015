"""The served app with a real viser server and headless tabs (no browser): opening a
reconstruction with its photos, reopening a saved session exactly, and a crashing solver
shown in the page."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
from helpers import GaussianSolver, drag, ict_baseline, landmarks_close, open_tab

from naseview.app.guard import guarded_viser_server
from naseview.app.naseview_app import NaseviewApp
from naseview.editing.baseline import Baseline
from naseview.facemodel import load_face_model
from naseview.meshio import read_mesh
from naseview.reconstruction import read_reconstruction, write_reconstruction
from naseview.testbed.synth import synthesize_case
from naseview.texture.mesh_files import mesh_file


@pytest.fixture(scope="module")
def baseline() -> Baseline:
    return ict_baseline()


@pytest.fixture(scope="module")
def reconstruction_dir(tmp_path_factory):
    """A `naseview reconstruct`-style output directory made from a synthetic case's
    ground truth (so this test does not depend on the pipeline), with the case's photos
    in a folder inside it (an output follows no path leaving its folder)."""
    out = tmp_path_factory.mktemp("app")
    model = load_face_model("ict")
    case = synthesize_case(out / "case", model, seed=1, size=512).parent
    rec = read_reconstruction(case / "truth.json")
    rec.extra["case_dir"] = str(case)            # absolute, as older versions wrote it
    write_reconstruction(rec, out / "reconstruction.json")
    shutil.copy(case / "truth_face.ply", out / "face.ply")
    V, F = read_mesh(out / "face.ply")
    (out / "nose.ply").write_bytes(mesh_file(V, F, "ply", model.nose_vertices))
    return out


def test_app_opens_reconstruction_with_photos_and_session_reopens_exactly(
        reconstruction_dir, tmp_path):
    servers = []
    apps = []
    tabs = []
    try:
        server = guarded_viser_server("127.0.0.1", 0, verbose=False)
        servers.append(server)
        app = NaseviewApp(server)
        apps.append(app)
        app.open(reconstruction_dir)
        assert app.wait_ready(60)
        tab, screen = open_tab(server, app)
        tabs.append(tab)
        assert app.case is not None and len(screen.scene.frustums) == 4
        assert screen.panels.photo.visible
        assert "front" in screen.panels.residuals.content
        assert "RMS" in screen.panels.residuals.content
        ctl = app.controller
        drag(ctl, "prn", np.array([0.0, 1.0, 1.0]))
        drag(ctl, "al_r", np.array([-1.0, 0.0, 0.0]))
        ctl.undo()
        assert ctl.wait_idle(30)
        name, data = app.file_for("session", "json")
        assert name.endswith("-session.json")
        # a downloaded session stores no path; kept in the patient's case folder it finds
        # the photos there
        assert json.loads(data)["app"]["case_dir"] is None
        session = reconstruction_dir / "case" / name
        session.write_bytes(data)
        fname, stl = app.file_for("mesh", "stl", part="nose", state="simulated")
        (tmp_path / fname).write_bytes(stl)
        Vn, _ = read_mesh(tmp_path / fname)
        assert len(Vn) < len(ctl.baseline.V)

        server2 = guarded_viser_server("127.0.0.1", 0, verbose=False)
        servers.append(server2)
        app2 = NaseviewApp(server2)
        apps.append(app2)
        tab2, screen2 = open_tab(server2, app2)     # a tab open while the session loads
        tabs.append(tab2)
        app2.open(session)                          # what `naseview serve SESSION` does
        assert app2.wait_ready(60)
        c2 = app2.controller
        assert np.array_equal(c2.simulation.V, ctl.simulation.V)
        assert landmarks_close(c2.landmarks, ctl.landmarks)
        assert c2.history_index == ctl.history_index and c2.can_redo
        assert app2.case is not None and app2.case_id == app.case_id
        np.testing.assert_array_equal(np.asarray(screen2.scene.nose.vertices),
                                      np.asarray(screen.scene.nose.vertices))
    finally:
        for t in tabs:
            t.close()
        for a in apps:
            a.close()
        for s in servers:
            s.stop()


def test_app_shows_a_crashed_solve_in_the_page_and_keeps_serving(baseline):
    def factory(b, params, iters):
        return GaussianSolver(b, fail_if="c"), ["prn", "c"], b.nose_ids

    server = guarded_viser_server("127.0.0.1", 0, verbose=False)
    app = NaseviewApp(server, solver_factory=factory)
    tab = None
    try:
        app.open_baseline(baseline, case_id="crash")
        assert app.wait_ready(60)
        tab, screen = open_tab(server, app)
        drag(app.controller, "c", np.array([0.0, 1.0, 0.0]))
        assert app.controller.wait_idle(10)
        assert screen.panels.error.visible
        assert "solver exploded" in screen.panels.error.content
        drag(app.controller, "prn", np.array([0.0, 1.0, 0.0]))  # c still moved: fails again
        app.controller.undo()
        app.controller.undo()
        assert app.controller.wait_idle(10)
        drag(app.controller, "prn", np.array([0.0, 1.0, 0.0]))
        assert app.controller.wait_idle(10)
        assert not screen.panels.error.visible                   # recovered
        assert np.abs(np.asarray(screen.scene.nose.vertices)
                      - baseline.V[screen.scene.nose_ids]).max() > 0.5
    finally:
        if tab is not None:
            tab.close()
        app.close()
        server.stop()
