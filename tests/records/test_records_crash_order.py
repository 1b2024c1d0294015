"""Issue 26, item 6: a crash between a parameter change's reconstruction commit and the
simulation's next autosave does not orphan the simulation: the next start reopens it
(as saved, with its edits), never an empty "Simulation 2"."""

from __future__ import annotations

import numpy as np
from helpers import drag
from records_fixtures import Patient, grid_result

from naseview.app.patient_work import PatientWork
from naseview.records import PatientRecords


def test_the_latest_simulation_reopens_after_a_crash_between_the_commits(patient: Patient):
    ctl = patient.controller()
    auto = patient.records.start_simulation(patient.pid, ctl, delay=60.0,
                                            reconstruction_sha256=patient.saved.sha256)
    drag(ctl, "prn", np.array([0.0, 0.0, 2.0]))
    assert auto.flush() and auto.error is None
    edited = ctl.landmarks["prn"].copy()
    # a parameter change: the new reconstruction is committed ...
    case = patient.records.folders.case_dir(patient.pid)
    patient.records.save_reconstruction(patient.pid, grid_result(case, lift=1.0))
    # ... and the server is killed before the simulation follows (no close, no flush)
    ctl.close()

    work = PatientWork(patient.records.folders.root)
    try:
        plan = work.begin(patient.pid)
        assert plan.session is not None, plan.problems
        assert plan.session.record is not None and plan.session.record.name == "Simulation 1"
        np.testing.assert_allclose(plan.session.landmarks["prn"], edited)
        assert any("opened as it was saved" in p for p in plan.problems)
        assert all("\n" not in p for p in plan.problems)
    finally:
        work.close()


def test_a_simulation_on_the_current_reconstruction_is_still_preferred(patient: Patient):
    """An older simulation made on an earlier reconstruction does not take over."""
    r = patient.records
    ctl = patient.controller()
    old = r.start_simulation(patient.pid, ctl, reconstruction_sha256=patient.saved.sha256,
                             name="Old", delay=60.0)
    old.close()
    case = r.folders.case_dir(patient.pid)
    saved = r.save_reconstruction(patient.pid, grid_result(case, lift=1.0))
    new = r.start_simulation(patient.pid, ctl, reconstruction_sha256=saved.sha256,
                             name="New", delay=60.0)
    new.close()
    ctl.close()
    work = PatientWork(PatientRecords(r.folders.root).folders.root)
    try:
        plan = work.begin(patient.pid)
        assert plan.session is not None and plan.session.record is not None
        assert plan.session.record.name == "New"
    finally:
        work.close()
