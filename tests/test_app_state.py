"""The app's editor state and controller, without a browser.

The face is the ICT mean face (read from ``NASEVIEW_ICT_MODEL``, never copied) with its
annotated landmarks, nose region and curves; the solver is either the real stage 3 deformer
(:class:`naseview.editing.solver.NoseEditSolver`) or, where a test needs a controllable
solver (slow, failing), a simple Gaussian displacement field defined here.
"""

from __future__ import annotations

import json
import os
import threading
import time
from collections.abc import Mapping

import numpy as np
import pytest

from naseview.editing.state import (
    MIRROR,
    Baseline,
    EditController,
    Solved,
    load_session,
    save_session,
)
from naseview.errors import NaseviewError
from naseview.measurements import clinical_measurements


def ict_baseline() -> Baseline:
    """The ICT mean face as a reconstruction in the SPEC frame (origin at g)."""
    from naseview.editing.baseline import baseline_from_face_model
    from naseview.facemodel import load_face_model

    assert os.environ.get("NASEVIEW_ICT_MODEL"), "conftest sets NASEVIEW_ICT_MODEL"
    return baseline_from_face_model(load_face_model("ict"))


class GaussianSolver:
    """Test-only deformation: each nose vertex moves by the Gaussian-weighted (sigma
    6 mm) sum of the landmark displacements; optional delay and failure trigger."""

    def __init__(self, baseline: Baseline, delay: float = 0.0,
                 fail_if: str | None = None) -> None:
        self.b = baseline
        self.delay = delay
        self.fail_if = fail_if
        self.calls = 0

    def __call__(self, landmarks: Mapping[str, np.ndarray],
                 interactive: bool = False) -> Solved:
        self.calls += 1
        if self.delay:
            time.sleep(self.delay)
        b = self.b
        V = b.V.copy()
        P = V[b.nose_ids]
        for k, p in landmarks.items():
            d = np.asarray(p) - b.landmarks[k]
            if np.any(d):
                if k == self.fail_if:
                    raise RuntimeError("solver exploded (test)")
                w = np.exp(-np.sum((b.V[b.nose_ids] - b.landmarks[k]) ** 2, 1) / 72.0)
                P = P + w[:, None] * d
        V[b.nose_ids] = P
        curves = {n: c + 0.0 for n, c in b.curves.items()}
        return Solved(V, curves, b.ad_landmarks.copy(),
                      clinical_measurements(landmarks, curves, V, b.F))


@pytest.fixture(scope="module")
def baseline() -> Baseline:
    return ict_baseline()


@pytest.fixture(scope="module")
def real_solver_factory(baseline: Baseline):
    from naseview.editing.solver import NoseEditSolver

    return lambda: NoseEditSolver(baseline)


def drag(ctl: EditController, lid: str, delta: np.ndarray, steps: int = 5) -> None:
    """A drag as the browser sends it: start, several updates, end."""
    start = ctl.landmarks[lid]
    ctl.begin_drag(lid)
    for s in range(1, steps + 1):
        ctl.drag_to(lid, start + delta * s / steps)
    ctl.end_drag()


def test_drag_moves_nose_and_undo_redo_restore_exactly(baseline, real_solver_factory):
    ctl = EditController(baseline, real_solver_factory())
    try:
        prn_v = int(np.argmin(np.linalg.norm(baseline.V - baseline.landmarks["prn"], axis=1)))
        drag(ctl, "prn", np.array([0.0, 2.0, 1.5]))
        assert ctl.wait_idle(30)
        sim = ctl.simulation
        assert not sim.interactive
        moved = np.linalg.norm(sim.V - baseline.V, axis=1)
        # the tip vertex follows the handle to within the ARAP tolerance
        np.testing.assert_allclose(sim.V[prn_v], baseline.landmarks["prn"] + [0, 2.0, 1.5],
                                   atol=1e-3)
        outside = np.setdiff1d(np.arange(len(baseline.V)), ctl_region(baseline))
        assert moved[outside].max() == 0.0          # nothing outside the nose region moves
        assert sim.measurements["nasal_length"] != baseline.measurements["nasal_length"]
        assert ctl.history_length == 2 and ctl.can_undo and not ctl.can_redo
        after = sim.V.copy()

        assert ctl.undo()
        assert ctl.wait_idle(30)
        assert np.array_equal(ctl.simulation.V, baseline.V)
        assert all(np.array_equal(ctl.landmarks[k], baseline.landmarks[k])
                   for k in baseline.landmarks)
        assert ctl.simulation.measurements == baseline.measurements
        assert ctl.redo()
        assert ctl.wait_idle(30)
        assert np.array_equal(ctl.simulation.V, after)
        assert not ctl.undo() or ctl.wait_idle(30)
        assert not ctl.undo()                       # nothing before the reconstruction
    finally:
        ctl.close()


def ctl_region(baseline: Baseline) -> np.ndarray:
    from naseview.editing.solver import NoseEditSolver

    return NoseEditSolver(baseline).region_ids


def test_one_undo_entry_per_drag_and_reset(baseline):
    ctl = EditController(baseline, GaussianSolver(baseline))
    try:
        drag(ctl, "prn", np.array([0.0, 1.0, 0.0]), steps=8)
        drag(ctl, "al_l", np.array([1.0, 0.0, 0.0]), steps=8)
        assert ctl.wait_idle(10)
        assert ctl.history_length == 3
        edited = ctl.simulation.V.copy()
        ctl.reset()
        assert ctl.wait_idle(10)
        assert np.array_equal(ctl.simulation.V, baseline.V)
        assert not ctl.is_edited() and ctl.history_length == 4
        ctl.undo()                                   # reset is undoable
        assert ctl.wait_idle(10)
        assert np.array_equal(ctl.simulation.V, edited)
        drag(ctl, "c", np.array([0.0, -1.0, 0.0]))   # a new edit drops the redo branch
        assert not ctl.can_redo
    finally:
        ctl.close()


def test_symmetric_drag_mirrors_partner(baseline):
    ctl = EditController(baseline, GaussianSolver(baseline))
    try:
        ctl.set_symmetric(True)
        d = np.array([1.5, -0.5, 0.8])
        drag(ctl, "al_l", d)
        lms = ctl.landmarks
        np.testing.assert_allclose(lms["al_l"] - baseline.landmarks["al_l"], d, atol=1e-12)
        np.testing.assert_allclose(lms["al_r"] - baseline.landmarks["al_r"], d * MIRROR,
                                   atol=1e-12)
        # the mirror of the moved left alare is where the right one went (symmetric face)
        np.testing.assert_allclose(lms["al_l"] * MIRROR, lms["al_r"], atol=1e-6)
        drag(ctl, "prn", np.array([0.7, 1.0, 0.0]))  # midline keeps its x
        assert ctl.landmarks["prn"][0] == baseline.landmarks["prn"][0]
        assert ctl.landmarks["prn"][1] == pytest.approx(baseline.landmarks["prn"][1] + 1.0)
        ctl.undo()
        ctl.undo()
        assert not ctl.is_edited()
        ctl.set_symmetric(False)
        drag(ctl, "al_l", d)
        assert np.array_equal(ctl.landmarks["al_r"], baseline.landmarks["al_r"])
        assert ctl.wait_idle(10)
        sim = ctl.simulation
        i = int(np.argmin(np.linalg.norm(baseline.V - baseline.landmarks["al_l"], axis=1)))
        assert np.linalg.norm(sim.V[i] - baseline.V[i]) > 0.5
    finally:
        ctl.close()


def test_latest_request_wins_and_stale_requests_are_dropped(baseline):
    solver = GaussianSolver(baseline, delay=0.05)
    ctl = EditController(baseline, solver)
    published: list[int] = []
    ctl.on_simulation.append(lambda s: published.append(s.revision))
    try:
        start = ctl.landmarks["prn"]
        ctl.begin_drag("prn")
        for i in range(1, 41):
            ctl.drag_to("prn", start + [0, 0.05 * i, 0])
            time.sleep(0.002)
        ctl.end_drag()
        assert ctl.wait_idle(10)
        assert solver.calls < 20                    # most of the 41 requests were dropped
        assert published == sorted(published)        # published in order
        np.testing.assert_allclose(ctl.simulation.landmarks["prn"], start + [0, 2.0, 0])
        assert ctl.simulation.landmarks["prn"][1] == ctl.landmarks["prn"][1]
    finally:
        ctl.close()


def test_callbacks_from_many_threads_do_not_break_state(baseline):
    ctl = EditController(baseline, GaussianSolver(baseline, delay=0.002))
    try:
        def worker(lid: str) -> None:
            for _ in range(5):
                drag(ctl, lid, np.array([0.0, 0.2, 0.0]), steps=3)

        ts = [threading.Thread(target=worker, args=(k,)) for k in ("prn", "c", "al_l")]
        for t in ts:
            t.start()
        for t in ts:
            t.join()
        assert ctl.wait_idle(10)
        assert landmarks_close(ctl.simulation.landmarks, ctl.landmarks)
        while ctl.undo():
            pass
        assert ctl.wait_idle(10)
        assert np.array_equal(ctl.simulation.V, baseline.V)
    finally:
        ctl.close()


def landmarks_close(a: Mapping[str, np.ndarray], b: Mapping[str, np.ndarray]) -> bool:
    return a.keys() == b.keys() and all(np.array_equal(a[k], b[k]) for k in a)


def test_failed_solve_is_reported_and_editor_keeps_working(baseline):
    ctl = EditController(baseline, GaussianSolver(baseline, fail_if="c"))
    errors: list[str | None] = []
    ctl.on_error.append(errors.append)
    try:
        drag(ctl, "prn", np.array([0.0, 1.0, 0.0]))
        assert ctl.wait_idle(10)
        good = ctl.simulation
        drag(ctl, "c", np.array([0.0, 1.0, 0.0]))
        assert ctl.wait_idle(10)
        assert ctl.error is not None and "solver exploded" in ctl.error
        assert errors and errors[-1] == ctl.error
        assert ctl.simulation is good                # last good result stays on screen
        ctl.undo()                                   # back to a solvable state
        assert ctl.wait_idle(10)
        drag(ctl, "prn", np.array([0.0, 0.5, 0.0]))
        assert ctl.wait_idle(10)
        assert ctl.error is None and errors[-1] is None
    finally:
        ctl.close()


def test_session_round_trip_reopens_exactly(baseline, real_solver_factory, tmp_path):
    ctl = EditController(baseline, real_solver_factory())
    try:
        ctl.set_symmetric(True)
        drag(ctl, "al_l", np.array([1.2, 0.3, -0.4]))
        drag(ctl, "prn", np.array([0.0, 1.5, 1.0]))
        ctl.undo()
        assert ctl.wait_idle(30)
        path = save_session(tmp_path / "s.json", ctl, {"case_id": "ict", "case_dir": None})
        saved_V = ctl.simulation.V.copy()
        saved_meas = dict(ctl.simulation.measurements)
        saved_lms = ctl.landmarks
        saved_curves = {k: v.copy() for k, v in ctl.simulation.curves.items()}
    finally:
        ctl.close()
    assert json.loads(path.read_text())["format"] == "naseview.session/1"
    session = load_session(path)
    assert session.app["case_id"] == "ict"
    ctl2 = EditController.from_session(session, real_solver_factory())
    try:
        assert ctl2.symmetric
        assert np.array_equal(ctl2.simulation.V, saved_V)        # bit-identical
        assert np.array_equal(ctl2.baseline.V, baseline.V)
        assert np.array_equal(ctl2.baseline.F, baseline.F)
        assert ctl2.simulation.measurements == saved_meas
        assert landmarks_close(ctl2.landmarks, saved_lms)
        for k, c in saved_curves.items():
            assert np.array_equal(ctl2.simulation.curves[k], c)
        assert ctl2.history_length == 3 and ctl2.history_index == 1 and ctl2.can_redo
        ctl2.redo()                                   # the undone drag is still there
        assert ctl2.wait_idle(30)
        np.testing.assert_allclose(ctl2.landmarks["prn"],
                                   baseline.landmarks["prn"] + [0, 1.5, 1.0], atol=1e-12)
        ctl2.undo()
        ctl2.undo()
        assert ctl2.wait_idle(30)
        assert np.array_equal(ctl2.simulation.V, baseline.V)
    finally:
        ctl2.close()


def test_bad_session_files_give_one_line_errors(tmp_path):
    p = tmp_path / "x.json"
    p.write_text('{"format": "naseview.case/1"}')
    with pytest.raises(NaseviewError, match="format"):
        load_session(p)
    p.write_text('{"format": "naseview.session/1", "baseline": {"mesh": {}}, "edit": {}}')
    with pytest.raises(NaseviewError, match="baseline"):
        load_session(p)
    p.write_text("{not json")
    with pytest.raises(NaseviewError, match="invalid JSON"):
        load_session(p)


def test_rebase_keeps_landmark_displacements(baseline):
    ctl = EditController(baseline, GaussianSolver(baseline))
    try:
        drag(ctl, "prn", np.array([0.0, 1.0, 0.0]))
        shifted = Baseline(baseline.V + [0, 0, 1.0], baseline.F, baseline.nose_ids,
                           {k: v + [0, 0, 1.0] for k, v in baseline.landmarks.items()},
                           baseline.curves, baseline.ad_landmarks, baseline.measurements)
        ctl.rebase(shifted, GaussianSolver(shifted))
        assert ctl.wait_idle(10)
        np.testing.assert_allclose(ctl.landmarks["prn"],
                                   baseline.landmarks["prn"] + [0, 1.0, 1.0], atol=1e-12)
        np.testing.assert_allclose(ctl.landmarks["c"], shifted.landmarks["c"], atol=0)
        ctl.undo()
        assert ctl.wait_idle(10)
        assert np.array_equal(ctl.simulation.V, shifted.V)
    finally:
        ctl.close()


def test_edit_solver_follows_handles_and_keeps_unedited_nose(baseline, real_solver_factory):
    solver = real_solver_factory()
    assert {"prn", "al_l", "al_r", "c", "sn"} <= set(solver.editable)
    assert not {"g", "mf_l", "mf_r"} & set(solver.editable)
    rest = solver(baseline.landmarks)
    assert np.abs(rest.V - baseline.V).max() < 0.01           # no edit, no change
    lms = dict(baseline.landmarks)
    lms["prn"] = lms["prn"] + [0.0, 0.0, 2.0]
    out = solver(lms)
    mid = out.curves["mid"]
    i = int(np.argmin(np.linalg.norm(baseline.curves["mid"] - baseline.landmarks["prn"], axis=1)))
    assert np.linalg.norm(mid[i] - lms["prn"]) < 0.05         # the mid-curve follows prn
    assert out.measurements["nasal_length"] > baseline.measurements["nasal_length"] + 1.0
    outside = np.setdiff1d(np.arange(len(baseline.V)), solver.region_ids)
    assert np.abs(out.V[outside] - baseline.V[outside]).max() == 0.0
    far = np.linalg.norm(baseline.V - baseline.landmarks["prn"], axis=1) > 30
    assert np.abs(out.V[far] - baseline.V[far]).max() < 0.1   # the edit stays local


def test_scene_update_sends_only_the_nose(baseline):
    """With a real viser server (no browser): a solve updates the nose mesh handle and
    never resends the rest of the face."""
    import viser

    from naseview.app.scene import FaceScene

    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    ctl = EditController(baseline, GaussianSolver(baseline))
    try:
        scene = FaceScene(server, ctl, ["prn", "al_l", "al_r"], region=baseline.nose_ids)
        sent: list[object] = []
        ws = server._websock_server
        orig = ws.queue_message
        ws.queue_message = lambda m: (sent.append(m), orig(m))[1]
        before = np.asarray(scene.nose.vertices).copy()
        drag(ctl, "prn", np.array([0.0, 1.5, 0.0]))
        assert ctl.wait_idle(10)
        after = np.asarray(scene.nose.vertices)
        assert np.abs(after - before).max() > 0.5
        names = {getattr(m, "name", "") for m in sent}
        assert "/face/nose" in names and "/face/rest" not in names
        np.testing.assert_allclose(
            np.asarray(scene.spheres.batched_positions)[0], ctl.landmarks["prn"], atol=1e-4)
        scene.set_view(colormap=True)
        assert scene.colormap is not None and scene.colormap_limit >= 1.0
        scene.remove()
    finally:
        ctl.close()
        server.stop()


def test_split_region_and_colour_map():
    from naseview.app.scene import diverging_colors, nice_limit, split_region

    F = np.array([[0, 1, 2], [1, 3, 2], [3, 4, 2], [4, 5, 2]])
    part, pf, rest, rf = split_region(F, np.array([1]), 6)
    assert set(part) == {0, 1, 2, 3} and set(rest) == {2, 3, 4, 5}
    assert 1 not in set(rest)                     # region vertices never in the rest mesh
    assert part[pf].tolist() == [[0, 1, 2], [1, 3, 2]]
    c = diverging_colors(np.array([-2.0, 0.0, 2.0]), 2.0)
    assert c[0, 2] > c[0, 0] and c[2, 0] > c[2, 2] and (c[1] > 240).all()
    assert nice_limit(0.0) == 0.5 and nice_limit(2.2) == 3.0


def test_exports_readable(baseline, tmp_path):
    from naseview.app.export import landmarks_csv, measurements_csv, measurements_json, mesh_file
    from naseview.meshio import read_mesh

    for t in ("stl", "obj", "ply", "glb"):
        data = mesh_file(baseline.V, baseline.F, t, baseline.nose_ids)
        (tmp_path / f"n.{t}").write_bytes(data)
        V, F = read_mesh(tmp_path / f"n.{t}")
        assert 0 < len(F) < len(baseline.F)
        assert np.abs(V.min(0) - baseline.V[baseline.nose_ids].min(0)).max() < 1.0
    lms = dict(baseline.landmarks)
    lms["prn"] = lms["prn"] + [0, 0, 3.0]
    rows = landmarks_csv(lms, baseline.landmarks).decode().splitlines()
    assert len(rows) == 1 + len(lms)
    prn = next(r for r in rows if r.startswith("prn,"))
    assert prn.split(",")[-1] == "3.0000"
    sim = clinical_measurements(lms, None)
    js = json.loads(measurements_json(baseline.measurements, sim))
    m = js["measurements"]["nasal_length"]
    assert m["change"] == pytest.approx(m["simulated"] - m["original"])
    assert "nasal_length" in measurements_csv(baseline.measurements, sim).decode()


@pytest.fixture(scope="module")
def reconstruction_dir(tmp_path_factory):
    """A `naseview reconstruct`-style output directory made from a synthetic case's
    ground truth (so this test does not depend on the pipeline), with the case's photos."""
    import shutil

    from naseview.app.export import mesh_file
    from naseview.facemodel import load_face_model
    from naseview.meshio import read_mesh
    from naseview.reconstruction import read_reconstruction, write_reconstruction
    from naseview.testbed.synth import synthesize_case

    root = tmp_path_factory.mktemp("app")
    model = load_face_model("ict")
    case = synthesize_case(root / "case", model, seed=1, size=512).parent
    out = root / "out"
    out.mkdir()
    rec = read_reconstruction(case / "truth.json")
    rec.extra["case_dir"] = str(case)
    write_reconstruction(rec, out / "reconstruction.json")
    shutil.copy(case / "truth_face.ply", out / "face.ply")
    V, F = read_mesh(out / "face.ply")
    (out / "nose.ply").write_bytes(mesh_file(V, F, "ply", model.nose_vertices))
    return out


def test_app_opens_reconstruction_with_photos_and_session_reopens_exactly(
        reconstruction_dir, tmp_path):
    import viser

    from naseview.app.serve import NaseviewApp
    from naseview.meshio import read_mesh

    servers = []
    apps = []
    try:
        server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
        servers.append(server)
        app = NaseviewApp(server)
        apps.append(app)
        app.open(reconstruction_dir)
        assert app.wait_ready(60)
        assert app.case is not None and len(app.scene.frustums) == 4
        assert app.panels.photo.visible
        assert "front" in app.panels.residuals.content and "RMS" in app.panels.residuals.content
        ctl = app.controller
        drag(ctl, "prn", np.array([0.0, 1.0, 1.0]))
        drag(ctl, "al_r", np.array([-1.0, 0.0, 0.0]))
        ctl.undo()
        assert ctl.wait_idle(30)
        name, data = app.file_for("session", "json")
        assert name.endswith("-session.json")
        session = tmp_path / name
        session.write_bytes(data)
        fname, stl = app.file_for("mesh", "stl", part="nose", state="simulated")
        (tmp_path / fname).write_bytes(stl)
        Vn, _ = read_mesh(tmp_path / fname)
        assert len(Vn) < len(ctl.baseline.V)

        server2 = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
        servers.append(server2)
        app2 = NaseviewApp(server2)
        apps.append(app2)
        app2.open(session)                          # what `naseview serve SESSION` does
        assert app2.wait_ready(60)
        c2 = app2.controller
        assert np.array_equal(c2.simulation.V, ctl.simulation.V)
        assert landmarks_close(c2.landmarks, ctl.landmarks)
        assert c2.history_index == ctl.history_index and c2.can_redo
        assert app2.case is not None and app2.case_id == app.case_id
        np.testing.assert_array_equal(np.asarray(app2.scene.nose.vertices),
                                      np.asarray(app.scene.nose.vertices))
    finally:
        for a in apps:
            a.close()
        for s in servers:
            s.stop()


def test_app_shows_a_crashed_solve_in_the_page_and_keeps_serving(baseline):
    import viser

    from naseview.app.serve import NaseviewApp

    def factory(b, params, iters):
        return GaussianSolver(b, fail_if="c"), ["prn", "c"], b.nose_ids

    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    app = NaseviewApp(server, solver_factory=factory)
    try:
        app.open_baseline(baseline, case_id="crash")
        assert app.wait_ready(60)
        drag(app.controller, "c", np.array([0.0, 1.0, 0.0]))
        assert app.controller.wait_idle(10)
        assert app.panels.error.visible and "solver exploded" in app.panels.error.content
        drag(app.controller, "prn", np.array([0.0, 1.0, 0.0]))  # c still moved: fails again
        app.controller.undo()
        app.controller.undo()
        assert app.controller.wait_idle(10)
        drag(app.controller, "prn", np.array([0.0, 1.0, 0.0]))
        assert app.controller.wait_idle(10)
        assert not app.panels.error.visible                      # recovered
        assert np.abs(np.asarray(app.scene.nose.vertices)
                      - baseline.V[app.scene.nose_ids]).max() > 0.5
    finally:
        app.close()
        server.stop()
