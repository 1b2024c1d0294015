"""A simulation is saved by itself after every committed edit, atomically, a burst of
changes as one write, and reopens exactly in a fresh editor."""

from __future__ import annotations

import json
import os
import threading
import time

import numpy as np
import pytest
from helpers import drag, landmarks_close, wait_for
from records_fixtures import Patient

import naseview.records.autosave as autosave_module
from naseview.editing.controller import EditController
from naseview.editing.session import load_session
from naseview.errors import NaseviewError
from naseview.records import Autosave, PatientRecords
from naseview.records.simulations import read_simulation


def test_committed_edits_are_saved_and_reopen_exactly(patient: Patient):
    ctl = patient.controller()
    auto = patient.records.start_simulation(patient.pid, ctl, delay=0.05,
                                            reconstruction_sha256=patient.saved.sha256)
    first = auto.saves
    drag(ctl, "prn", np.array([0.0, 1.0, 2.0]))
    ctl.set_symmetric(True)
    drag(ctl, "al_l", np.array([0.5, 0.0, 0.0]))
    drag(ctl, "prn", np.array([0.0, -0.5, 0.0]))
    ctl.undo()
    wait_for(lambda: not auto.pending and auto.saves > first, 10, "the autosave")
    assert auto.error is None
    want_lms, want_V = ctl.landmarks, ctl.simulation.V.copy()
    assert ctl.history_length == 4 and ctl.history_index == 2
    ctl.close()                          # the server is gone; no close(), no flush

    # a fresh server: a new PatientRecords and a new controller from the saved file
    records = PatientRecords(patient.records.folders.root)
    opened = records.open_patient(patient.pid)
    assert opened.simulation is not None and opened.simulation.slug == auto.slug
    assert opened.simulation.name == "Simulation 1" and opened.problems == ()
    session = records.load_simulation(patient.pid, opened.simulation.slug)
    ctl2 = EditController.from_session(session, None)
    try:
        assert landmarks_close(ctl2.landmarks, want_lms)
        assert np.array_equal(ctl2.simulation.V, want_V)
        assert ctl2.symmetric
        assert (ctl2.history_length, ctl2.history_index) == (4, 2)
        assert ctl2.redo()                   # the undone drag is still there
        np.testing.assert_allclose(ctl2.landmarks["prn"],
                                   patient.baseline.landmarks["prn"] + [0, 0.5, 2.0])
    finally:
        ctl2.close()
    auto.close()


def test_a_burst_of_changes_is_one_write(patient: Patient):
    ctl = patient.controller()
    auto = patient.records.start_simulation(patient.pid, ctl, delay=30.0,
                                            reconstruction_sha256=patient.saved.sha256)
    drag(ctl, "prn", np.array([0.0, 1.0, 0.0]))
    for _ in range(10):                   # the surgeon clicks undo / redo quickly
        ctl.undo()
        time.sleep(0.01)                  # (the worker gets the processor in between)
        ctl.redo()
        time.sleep(0.01)
    ctl.undo()
    auto.close()
    assert auto.saves == 1, auto.saves       # written once, the last state
    s = read_simulation(patient.records.folders, patient.pid, auto.slug)
    assert s.history_index == 0 and len(s.history) == 2
    ctl.close()


def test_nothing_is_written_during_a_drag_and_closing_keeps_it(patient: Patient):
    ctl = patient.controller()
    auto = patient.records.start_simulation(patient.pid, ctl, delay=0.01,
                                            reconstruction_sha256=patient.saved.sha256)
    path = auto.path
    before = path.read_bytes()
    ctl.begin_drag("prn")
    ctl.drag_to("prn", patient.baseline.landmarks["prn"] + [0, 0, 1.0])
    auto.changed()                        # even when asked, a drag is not written
    assert not auto.flush() and path.read_bytes() == before
    assert ctl.dragging == "prn" and ctl.history_length == 1
    auto.close()                          # the tab closes mid-drag: the drag is kept
    s = load_session(path)
    assert len(s.history) == 2 and s.landmarks["prn"][2] == 1.0
    ctl.close()


def test_a_crash_mid_write_keeps_the_previous_file(patient: Patient, monkeypatch):
    ctl = patient.controller()
    auto = patient.records.start_simulation(patient.pid, ctl, delay=0.01,
                                            reconstruction_sha256=patient.saved.sha256)
    drag(ctl, "prn", np.array([0.0, 1.0, 0.0]))
    assert auto.flush()
    good = auto.path.read_bytes()
    errors: list[str] = []
    auto.on_error.append(errors.append)

    def full_disk(fd: int) -> None:           # the data is half out when the disk fills
        raise OSError(28, "No space left on device")

    monkeypatch.setattr("naseview.fileio.os.fsync", full_disk)
    drag(ctl, "prn", np.array([0.0, 1.0, 0.0]))
    assert not auto.flush()
    assert auto.error is not None and "the disk is full" in auto.error
    assert "\n" not in auto.error and errors == [auto.error]
    assert auto.path.read_bytes() == good                  # the previous file, whole
    with auto._save_lock:                     # the worker's own retry is not mid-write
        assert [p.name for p in auto.path.parent.iterdir()] == [auto.path.name]  # no .tmp
    monkeypatch.undo()
    ctl.undo()                                # the editor goes on; the next save works
    assert auto.flush() and auto.error is None
    assert json.loads(auto.path.read_text())["edit"]["history_index"] == 1
    auto.close()
    ctl.close()


def test_an_autosave_never_blocks_the_editor(patient: Patient, monkeypatch):
    """The listener returns at once even while a write is under way (slow disk)."""
    ctl = patient.controller()
    auto = patient.records.start_simulation(patient.pid, ctl, delay=0.0,
                                            reconstruction_sha256=patient.saved.sha256)
    gate, writing = threading.Event(), threading.Event()
    real = autosave_module.atomic_write_bytes

    def slow(path: os.PathLike[str], data: bytes) -> os.PathLike[str]:
        writing.set()
        assert gate.wait(10)
        return real(path, data)

    monkeypatch.setattr(autosave_module, "atomic_write_bytes", slow)
    try:
        drag(ctl, "prn", np.array([0.0, 1.0, 0.0]))
        assert writing.wait(10)               # the worker is stuck in the write
        ctl.undo()                            # the editor still answers
        ctl.redo()
        assert ctl.history_index == 1
    finally:
        gate.set()
    auto.close()
    ctl.close()
    assert load_session(auto.path).history_index == 1


def test_a_bad_name_is_one_line(patient: Patient):
    ctl = patient.controller()
    try:
        with pytest.raises(NaseviewError, match="a name is 1 to 80"):
            Autosave(patient.records.folders, patient.pid, "x", ctl, name="")
        with pytest.raises(NaseviewError, match="not a simulation name"):
            Autosave(patient.records.folders, patient.pid, "../x", ctl, name="x")
    finally:
        ctl.close()


def test_another_window_saving_the_same_simulation_is_never_overwritten(patient: Patient):
    """Two servers (two PatientRecords) editing one simulation: the second writer is told
    in one line and the first one's edit stays on disk (no silent last-writer-wins)."""
    ctl_a = patient.controller()
    auto_a = patient.records.start_simulation(patient.pid, ctl_a, delay=0.05,
                                              reconstruction_sha256=patient.saved.sha256)
    other = PatientRecords(patient.records.folders.root)
    session = other.load_simulation(patient.pid, auto_a.slug)
    ctl_b = EditController.from_session(session, None)
    auto_b = other.resume_simulation(patient.pid, auto_a.slug, ctl_b, session, delay=0.05)
    try:
        drag(ctl_a, "prn", np.array([0.0, 0.0, 2.0]))
        assert auto_a.flush() and auto_a.error is None
        a_prn = ctl_a.landmarks["prn"].copy()
        drag(ctl_b, "prn", np.array([0.0, 2.0, 0.0]))      # B's own edit of the tip
        auto_b.flush()
        assert auto_b.error is not None and "another naseview window" in auto_b.error
        assert "\n" not in auto_b.error
        saved = read_simulation(patient.records.folders, patient.pid, auto_a.slug)
        np.testing.assert_allclose(saved.landmarks["prn"], a_prn)
    finally:
        auto_b.close()
        other.close()
        ctl_b.close()
        auto_a.close()
        ctl_a.close()
