"""Named simulations: independent of each other, renamed, duplicated, deleted to the
trash; a simulation made on an earlier reconstruction, or a hand-edited file, is one line
and never opened silently wrong."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest
from helpers import drag
from records_fixtures import Patient, grid_result

from naseview.editing.controller import EditController
from naseview.errors import NaseviewError
from naseview.records.simulations import MAX_SIMULATION_BYTES


def _sim_file(patient: Patient, slug: str) -> Path:
    return patient.records.folders.simulation_file(patient.pid, slug)


def test_two_named_simulations_stay_independent(patient: Patient):
    r, pid, sha = patient.records, patient.pid, patient.saved.sha256
    a_ctl, b_ctl = patient.controller(), patient.controller()
    a = r.start_simulation(pid, a_ctl, reconstruction_sha256=sha, delay=0.01)
    b = r.start_simulation(pid, b_ctl, reconstruction_sha256=sha, delay=0.01)
    assert (a.name, b.name, a.slug, b.slug) == ("Simulation 1", "Simulation 2",
                                                "simulation-1", "simulation-2")
    drag(a_ctl, "prn", np.array([0.0, 0.0, 2.0]))
    drag(b_ctl, "al_l", np.array([1.0, 0.0, 0.0]))
    drag(b_ctl, "al_l", np.array([1.0, 0.0, 0.0]))
    assert a.flush() and b.flush()
    sa = r.load_simulation(pid, "simulation-1")
    sb = r.load_simulation(pid, "simulation-2")
    base = patient.baseline.landmarks
    assert sa.landmarks["prn"][2] == base["prn"][2] + 2 and np.array_equal(
        sa.landmarks["al_l"], base["al_l"]) and len(sa.history) == 2
    assert sb.landmarks["al_l"][0] == base["al_l"][0] + 2 and np.array_equal(
        sb.landmarks["prn"], base["prn"]) and len(sb.history) == 3
    names = {i.slug: i.name for i in r.simulations(pid)}
    assert names == {"simulation-1": "Simulation 1", "simulation-2": "Simulation 2"}
    # the open one is renamed through its autosave (its next write keeps the new name)
    r.rename_simulation(pid, "simulation-1", "Tip up 2 mm")
    drag(a_ctl, "prn", np.array([0.0, 0.0, 0.5]))
    assert a.flush()
    assert r.load_simulation(pid, "simulation-1").record.name == "Tip up 2 mm"
    with pytest.raises(NaseviewError, match="already has a simulation with that name"):
        r.rename_simulation(pid, "simulation-2", "tip UP 2 mm")
    with pytest.raises(NaseviewError, match="the simulation is open"):
        r.delete_simulation(pid, "simulation-2")
    a.close(), b.close()
    a_ctl.close(), b_ctl.close()


def test_duplicate_and_delete_to_the_trash(patient: Patient):
    r, pid = patient.records, patient.pid
    ctl = patient.controller()
    auto = r.start_simulation(pid, ctl, reconstruction_sha256=patient.saved.sha256,
                              name="Plan A", delay=0.01)
    drag(ctl, "prn", np.array([0.0, 1.0, 0.0]))
    auto.close()
    ctl.close()
    copy = r.duplicate_simulation(pid, "plan-a")
    assert (copy.name, copy.slug) == ("Plan A (copy)", "plan-a-copy")
    assert r.load_simulation(pid, copy.slug).landmarks["prn"][1] == \
        patient.baseline.landmarks["prn"][1] + 1
    where = r.delete_simulation(pid, "plan-a")
    assert where.parent == r.folders.trash_dir(pid) and where.is_file()
    assert [i.slug for i in r.simulations(pid)] == ["plan-a-copy"]
    assert json.loads(where.read_text())["record"]["name"] == "Plan A"   # restorable
    with pytest.raises(NaseviewError, match="simulation not found"):
        r.load_simulation(pid, "plan-a")


def test_a_simulation_of_an_earlier_reconstruction_is_reported(patient: Patient):
    r, pid = patient.records, patient.pid
    ctl = patient.controller()
    r.start_simulation(pid, ctl, reconstruction_sha256=patient.saved.sha256).close()
    ctl.close()
    # reconstructed again (other parameters): a new reconstruction.json
    r.save_reconstruction(pid, grid_result(r.folders.case_dir(pid), lift=0.5))
    opened = r.open_patient(pid)
    assert opened.reconstruction_dir == r.folders.reconstruction_dir(pid)
    assert opened.simulation is None                       # not opened silently wrong
    why = opened.stale["simulation-1"]
    assert "\n" not in why and str(_sim_file(patient, "simulation-1")) in why
    assert "record.reconstruction_sha256" in why and "earlier reconstruction" in why
    with pytest.raises(NaseviewError, match="earlier reconstruction"):
        r.load_simulation(pid, "simulation-1")
    s = r.load_simulation(pid, "simulation-1", allow_stale=True)   # as it was saved
    assert np.array_equal(s.baseline.V, patient.baseline.V)


def _edited(patient: Patient, edit) -> Path:
    ctl = patient.controller()
    auto = patient.records.start_simulation(patient.pid, ctl, delay=0.01,
                                            reconstruction_sha256=patient.saved.sha256)
    drag(ctl, "prn", np.array([0.0, 1.0, 0.0]))
    auto.close()
    ctl.close()
    obj = json.loads(auto.path.read_text())
    text = edit(obj)
    auto.path.write_text(text if isinstance(text, str) else json.dumps(obj))
    return auto.path


HOSTILE = [
    ("not JSON", lambda o: "{", "invalid JSON"),
    ("NaN", lambda o: json.dumps(o).replace('"history_index": 1', '"history_index": NaN'),
     "not a JSON number"),
    ("wrong type", lambda o: o["edit"].update(history="x"), "edit.history"),
    ("case outside", lambda o: o["app"].update(case_dir="../../../../etc"), "app.case_dir"),
    ("absolute case", lambda o: o["app"].update(case_dir="/etc"), "app.case_dir"),
    ("name", lambda o: o["record"].update(name="x" * 500), "record.name"),
    ("sha", lambda o: o["record"].update(reconstruction_sha256=7), "reconstruction_sha256"),
    ("no record", lambda o: o.pop("record"), "key 'record'"),
]


@pytest.mark.parametrize("what,edit,key", HOSTILE, ids=[h[0] for h in HOSTILE])
def test_a_hand_edited_simulation_is_one_line(patient: Patient, what, edit, key):
    path = _edited(patient, edit)
    with pytest.raises(NaseviewError) as e:
        patient.records.load_simulation(patient.pid, "simulation-1")
    msg = str(e.value)
    assert "\n" not in msg and str(path) in msg and key in msg, msg
    # the patient still opens; the simulation is listed with its problem
    opened = patient.records.open_patient(patient.pid)
    assert opened.simulation is None and key in opened.stale["simulation-1"]


def test_huge_and_linked_simulation_files_are_refused(patient: Patient, tmp_path: Path):
    r, pid = patient.records, patient.pid
    d = r.folders.simulations_dir(pid)
    d.mkdir(parents=True)
    huge = d / "huge.json"
    with open(huge, "wb") as f:
        f.truncate(MAX_SIMULATION_BYTES + 1)          # sparse: no disk used
    with pytest.raises(NaseviewError, match="larger than a simulation can be"):
        r.load_simulation(pid, "huge")
    outside = tmp_path / "elsewhere.json"
    outside.write_text("{}")
    os.symlink(outside, d / "link.json")
    assert [i.slug for i in r.simulations(pid)] == ["huge"]   # a link is no simulation
    with pytest.raises(NaseviewError, match="symbolic link"):
        r.load_simulation(pid, "link")
    for bad in ("../P001/x", "a/b", "x\0", "X" * 300, ""):
        with pytest.raises(NaseviewError, match="not a simulation name"):
            r.load_simulation(pid, bad)
    # a controller that never changes writes once (at creation), never again
    ctl = EditController(patient.baseline, None)
    auto = r.start_simulation(pid, ctl, reconstruction_sha256=None, delay=0.0)
    ctl.set_symmetric(False)
    assert auto.close() and auto.saves == 0
    ctl.close()
