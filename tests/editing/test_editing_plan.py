"""The surgical plan in the editor: manoeuvres set, combined with drags, undone, reset,
saved and reopened; hand-edited plans refused in one line.

The face is the ICT mean face; where the real deformation matters the solver is
:class:`naseview.editing.solver.NoseEditSolver`, else the quick ``helpers.GaussianSolver``
(which records the manoeuvres it was asked for).
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from helpers import GaussianSolver, drag

from naseview.editing.controller import EditController
from naseview.editing.session import load_session, save_session, session_from_json
from naseview.editing.solver import NoseEditSolver
from naseview.errors import NaseviewError
from naseview.measurements import clinical_measurements


@pytest.fixture()
def ctl(baseline):
    c = EditController(baseline, GaussianSolver(baseline))
    yield c
    c.close()


def test_a_slider_moved_in_one_go_is_one_undo_entry(ctl, baseline):
    for v in (0.5, 1.0, 1.5, 2.0):
        ctl.set_manoeuvre("hump_reduction", v)
    assert ctl.wait_idle(30)
    assert ctl.manoeuvres == {"hump_reduction": 2.0}
    assert ctl.history_length == 2
    assert ctl.simulation.manoeuvres == {"hump_reduction": 2.0}
    ctl.set_manoeuvre("tip_rotation", 3.0)          # another control: a new entry
    assert ctl.history_length == 3 and ctl.is_edited()
    assert ctl.undo() and ctl.wait_idle(30)
    assert ctl.manoeuvres == {"hump_reduction": 2.0}
    assert ctl.simulation.manoeuvres == {"hump_reduction": 2.0}
    assert ctl.undo() and ctl.wait_idle(30)
    assert ctl.manoeuvres == {} and not ctl.is_edited()
    assert np.array_equal(ctl.simulation.V, baseline.V)   # exactly the reconstruction
    assert ctl.redo() and ctl.redo() and ctl.wait_idle(30)
    assert ctl.manoeuvres == {"hump_reduction": 2.0, "tip_rotation": 3.0}


def test_a_value_set_after_undo_redo_is_a_new_entry(ctl):
    ctl.set_manoeuvre("hump_reduction", 1.0)
    assert ctl.undo() and ctl.redo()
    ctl.set_manoeuvre("hump_reduction", 2.0)        # the stop at 1 mm stays in the history
    assert ctl.history_length == 3
    assert ctl.undo() and ctl.manoeuvres == {"hump_reduction": 1.0}


def test_sliding_back_to_zero_leaves_no_empty_entry(ctl):
    ctl.set_manoeuvre("tip_projection", 1.0)
    ctl.set_manoeuvre("tip_projection", 0.0)
    assert ctl.manoeuvres == {} and ctl.history_length == 1 and not ctl.can_undo


def test_drags_and_manoeuvres_combine_and_reset_clears_both(ctl, baseline):
    ctl.set_manoeuvre("hump_reduction", 1.5)
    drag(ctl, "prn", np.array([0.0, 1.0, 0.0]))
    ctl.set_manoeuvre("hump_reduction", 2.0)        # after a drag: a new entry
    assert ctl.wait_idle(30)
    assert ctl.history_length == 4
    assert ctl.manoeuvres == {"hump_reduction": 2.0}
    assert not np.array_equal(ctl.landmarks["prn"], baseline.landmarks["prn"])
    ctl.reset()
    assert ctl.wait_idle(30)
    assert ctl.manoeuvres == {} and not ctl.is_edited()
    assert np.array_equal(ctl.simulation.V, baseline.V)
    assert ctl.undo() and ctl.wait_idle(30)         # reset is undoable
    assert ctl.manoeuvres == {"hump_reduction": 2.0}


def test_out_of_range_or_unknown_manoeuvre_is_refused_and_nothing_changes(ctl):
    with pytest.raises(NaseviewError, match="hump_reduction"):
        ctl.set_manoeuvre("hump_reduction", 50.0)
    with pytest.raises(NaseviewError, match="nose_job"):
        ctl.set_manoeuvre("nose_job", 1.0)
    with pytest.raises(NaseviewError):
        ctl.set_manoeuvres({"tip_rotation": float("nan")})
    assert ctl.manoeuvres == {} and ctl.history_length == 1


def test_the_plan_is_saved_and_reopens_exactly(baseline, tmp_path):
    solver = NoseEditSolver(baseline)
    ctl = EditController(baseline, solver)
    try:
        ctl.set_manoeuvre("hump_reduction", 1.0)
        ctl.set_manoeuvre("tip_rotation", 4.0)
        assert ctl.wait_idle(60)
        shown = ctl.simulation.shown_landmarks
        V = ctl.simulation.V.copy()
        path = save_session(tmp_path / "s.json", ctl)
    finally:
        ctl.close()
    s = load_session(path)
    assert s.manoeuvres == {"hump_reduction": 1.0, "tip_rotation": 4.0}
    assert s.history_manoeuvres == [{}, {"hump_reduction": 1.0},
                                    {"hump_reduction": 1.0, "tip_rotation": 4.0}]
    again = EditController.from_session(s, None)     # the saved mesh, shown as is
    try:
        assert again.manoeuvres == s.manoeuvres
        assert np.array_equal(again.simulation.V, V)
        assert all(np.array_equal(again.simulation.shown_landmarks[k], shown[k])
                   for k in shown)
        assert again.undo()
        assert again.manoeuvres == {"hump_reduction": 1.0}
    finally:
        again.close()


@pytest.mark.parametrize(("edit", "key"), [
    ({"manoeuvres": {"hump_reduction": 99}}, "hump_reduction"),
    ({"manoeuvres": {"nose_job": 1}}, "nose_job"),
    ({"manoeuvres": {"tip_rotation": "up"}}, "tip_rotation"),
    ({"manoeuvres": [1, 2]}, "manoeuvres"),
    ({"history_manoeuvres": [{}, {}]}, "history_manoeuvres"),
    ({"history_manoeuvres": [{"tip_projection": 4}]}, "history_manoeuvres.0"),
    ({"manoeuvres": False}, "manoeuvres"),
    ({"manoeuvres": {"tip_rotation": 10 ** 400}}, "tip_rotation"),
    ({"landmarks": {"prn": ["1", "2", "3"]}}, "edit.landmarks.prn"),
    ({"landmarks": {"prn": [True, True, True]}}, "edit.landmarks.prn"),
])
def test_hand_edited_plans_give_one_line_naming_the_key(baseline, tmp_path, edit, key):
    ctl = EditController(baseline, None)
    try:
        path = save_session(tmp_path / "s.json", ctl)
    finally:
        ctl.close()
    obj = json.loads(path.read_text())
    obj["edit"].update(edit)
    with pytest.raises(NaseviewError) as e:
        session_from_json(obj, "s.json")
    msg = str(e.value)
    assert "s.json" in msg and key in msg and "\n" not in msg


def test_the_solver_keeps_landmarks_on_the_manoeuvred_surface(baseline):
    solver = NoseEditSolver(baseline)
    out = solver(baseline.landmarks, manoeuvres={"tip_projection": 2.0,
                                                 "hump_reduction": 1.0})
    assert out.surface_landmarks is not None
    moved = np.linalg.norm(out.surface_landmarks["prn"] - baseline.landmarks["prn"])
    assert moved == pytest.approx(2.0, abs=0.1)
    # every landmark is drawn on the manoeuvred surface
    for k in solver.editable:
        d = np.linalg.norm(out.V - out.surface_landmarks[k], axis=1).min()
        assert d < 0.3, k
    # the measurements are those of the manoeuvred nose
    meas = clinical_measurements(out.surface_landmarks, None, out.V, baseline.F)
    assert out.measurements["nasal_length"] == pytest.approx(meas["nasal_length"])
    assert not any("folded" in w for w in out.warnings)


def test_a_reduction_past_the_hump_is_warned_and_the_ridge_stays_put(baseline):
    solver = NoseEditSolver(baseline)
    hump = baseline.measurements["dorsal_hump_depth"]
    dev = baseline.measurements["dorsal_deviation"]
    within = solver(baseline.landmarks, manoeuvres={"hump_reduction": round(hump, 1)})
    assert not any("saddle" in w for w in within.warnings)
    past = solver(baseline.landmarks, manoeuvres={"hump_reduction": 5.0})
    assert any("saddle" in w and "\n" not in w for w in past.warnings)
    # a symmetric lowering leaves the dorsum on the midline (no artefact of a hollow top)
    for out in (within, past):
        assert abs(out.measurements["dorsal_deviation"] - dev) < 0.3


def test_columella_setback_lowers_the_columellar_show(baseline):
    solver = NoseEditSolver(baseline)
    show = [solver(baseline.landmarks, manoeuvres={"columella_setback": a} if a else None)
            .measurements["columellar_show"] for a in (0.0, 2.0, 4.0)]
    assert show[0] > show[1] > show[2]


def test_alar_base_narrowing_leaves_the_tip_lobule_alone(baseline):
    solver = NoseEditSolver(baseline)
    off = solver.plan.landmark_offsets({"alar_base_narrowing": 4.0})
    lms = {k: baseline.landmarks[k] + off.get(k, 0.0) for k in baseline.landmarks}

    def width(a: str, b: str, p: dict) -> float:
        return float(np.linalg.norm(p[a] - p[b]))

    assert width("al_l", "al_r", baseline.landmarks) - width("al_l", "al_r", lms) \
        == pytest.approx(8.0, abs=0.1)                    # 4 mm each side
    assert abs(width("md_l", "md_r", baseline.landmarks) - width("md_l", "md_r", lms)) < 1.0
