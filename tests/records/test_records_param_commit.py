"""Issue 26: a parameter change is kept as soon as it is committed. The app saves the new
reconstruction, then rebases the editor on it; the simulation (new SHA-256, new baseline,
the parameters in ``app``) is written at once, not after the autosave's debounce, so a
crash in the second after it loses nothing; and no file pairs the new SHA-256 with the
old baseline."""

from __future__ import annotations

import time

import numpy as np
from helpers import GaussianSolver, drag
from records_fixtures import Patient, grid_result

from naseview.editing.baseline import baseline_from_pipeline
from naseview.records.simulations import read_simulation

DEBOUNCE = 30.0
"""The autosave's delay here: longer than the test, so only an immediate write passes."""


def _read(patient: Patient, slug: str):
    return read_simulation(patient.records.folders, patient.pid, slug)


def test_a_committed_parameter_change_is_written_at_once(patient: Patient):
    r = patient.records
    params = {"curves": {"alpha": 1.0}}
    ctl = patient.controller()
    auto = r.start_simulation(patient.pid, ctl, delay=DEBOUNCE, app_state=lambda: {
        "params": params}, reconstruction_sha256=patient.saved.sha256)
    try:
        drag(ctl, "prn", np.array([0.0, 0.0, 1.5]))
        assert auto.flush() and auto.error is None
        edited = ctl.landmarks["prn"] - patient.baseline.landmarks["prn"]
        # the surgeon changes a parameter: the app re-runs the pipeline with it ...
        params = {"curves": {"alpha": 2.0}}
        result = grid_result(r.folders.case_dir(patient.pid), lift=1.0)
        saved = r.save_reconstruction(patient.pid, result)       # ... keeps it ...
        auto.set_reconstruction(saved.sha256)
        time.sleep(0.3)                                          # (building the solver)
        s = _read(patient, auto.slug)                            # not yet on the new one
        assert s.record is not None
        assert s.record.reconstruction_sha256 == patient.saved.sha256
        assert np.allclose(s.baseline.V, patient.baseline.V)
        new = baseline_from_pipeline(result)
        ctl.rebase(new, GaussianSolver(new))                     # ... and commits it
        deadline = time.monotonic() + 10.0
        while time.monotonic() < deadline:
            s = _read(patient, auto.slug)
            if s.record is not None and s.record.reconstruction_sha256 == saved.sha256:
                break
            time.sleep(0.02)
        # a crash now: what the next start reads
        assert s.record is not None and s.record.reconstruction_sha256 == saved.sha256, \
            "the parameter change waited for the debounce"
        assert np.allclose(s.baseline.V, new.V)
        assert s.app["params"] == {"curves": {"alpha": 2.0}}
        np.testing.assert_allclose(s.landmarks["prn"] - new.landmarks["prn"], edited)
    finally:
        auto.close()
        ctl.close()
