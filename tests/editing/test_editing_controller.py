"""The editor's controller without a browser: drags, undo / redo, reset, symmetric mode,
the latest-request worker, failing solves and rebasing.

The face is the ICT mean face (read from ``NASEVIEW_ICT_MODEL``, never copied) with its
annotated landmarks, nose region and curves; the solver is either the real stage 3 deformer
(:class:`naseview.editing.solver.NoseEditSolver`) or, where a test needs a controllable
solver (slow, failing), a simple Gaussian displacement field (``helpers.GaussianSolver``).
"""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest
from helpers import GaussianSolver, drag, landmarks_close

from naseview.editing.baseline import Baseline
from naseview.editing.controller import MIRROR, EditController
from naseview.editing.solver import NoseEditSolver


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


def test_background_snapshot_leaves_an_open_drag_alone(baseline):
    """An autosave taken in the middle of a drag stores the last committed state and does
    not split the drag into two undo entries."""
    ctl = EditController(baseline, GaussianSolver(baseline))
    try:
        start = ctl.landmarks["prn"].copy()
        ctl.begin_drag("prn")
        ctl.drag_to("prn", start + [0, 1.0, 0])
        snap = ctl.snapshot(commit_drag=False)
        assert ctl.dragging == "prn"                       # still dragging
        np.testing.assert_array_equal(snap.landmarks["prn"], start)
        assert len(snap.history) == 1
        ctl.drag_to("prn", start + [0, 2.0, 0])
        ctl.end_drag()
        assert ctl.wait_idle(10)
        assert ctl.history_length == 2                     # one drag, one undo entry
        np.testing.assert_allclose(ctl.landmarks["prn"], start + [0, 2.0, 0])
        assert len(ctl.snapshot().history) == 2
    finally:
        ctl.close()
