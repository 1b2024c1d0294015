"""Session files of the editor: a round trip reopens exactly, bad files give one line."""

from __future__ import annotations

import json

import numpy as np
import pytest
from helpers import drag, landmarks_close

from naseview.editing.controller import EditController
from naseview.editing.session import load_session, save_session
from naseview.errors import NaseviewError


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
