"""The patient list (WORK/index.sqlite) says what the folders say: rebuilt when missing,
damaged, of another version or stale; a hostile index never opens a path outside WORK;
a locked index is a folder scan, not an error."""

from __future__ import annotations

import sqlite3
from pathlib import Path

import numpy as np
import pytest
from helpers import drag
from records_fixtures import Patient, grid_result, write_case_json

from naseview.errors import NaseviewError
from naseview.records import PatientRecords


def _listing(r: PatientRecords) -> list[tuple[str, bool, bool, list[str]]]:
    return [(p.patient_id, p.has_case, p.has_reconstruction,
             [s.name for s in p.simulations]) for p in r.list_patients()]


def _two_patients(patient: Patient, tmp_path: Path) -> PatientRecords:
    r = patient.records
    ctl = patient.controller()
    auto = r.start_simulation(patient.pid, ctl, reconstruction_sha256=patient.saved.sha256,
                              name="Plan A", delay=0.01)
    drag(ctl, "prn", np.array([0.0, 1.0, 0.0]))
    auto.close()
    ctl.close()
    case = write_case_json(tmp_path / "elsewhere" / "p2", "P002")   # opened later
    r.patient_for_case(case)
    return r


def test_the_list_is_what_the_folders_say(patient: Patient, tmp_path: Path):
    r = _two_patients(patient, tmp_path)
    want = [("P002", True, False, []), ("P001", True, True, ["Plan A"])]   # newest first
    assert _listing(r) == want and r.index.last_source == "rebuilt"
    assert _listing(r) == want and r.index.last_source == "index"
    # a change in a folder (a new simulation, written by another server) is seen
    ctl = patient.controller()
    PatientRecords(r.folders.root).start_simulation(
        "P001", ctl, reconstruction_sha256=None, name="Plan B").close()
    ctl.close()
    got = _listing(r)
    assert got[0] == ("P001", True, True, ["Plan B", "Plan A"]), got
    # deleted: rebuilt from the folders
    r.folders.index_file.unlink()
    assert _listing(r) == got and r.index.last_source == "rebuilt"


@pytest.mark.parametrize("damage", ["garbage", "truncated", "other version", "bad row"])
def test_a_damaged_index_is_rebuilt(patient: Patient, tmp_path: Path, damage: str):
    r = _two_patients(patient, tmp_path)
    want = _listing(r)
    f = r.folders.index_file
    if damage == "garbage":
        f.write_bytes(b"this is not a database" * 100)
        for extra in (Path(f"{f}-wal"), Path(f"{f}-shm")):
            extra.unlink(missing_ok=True)
    elif damage == "truncated":
        data = f.read_bytes()
        f.write_bytes(data[:len(data) // 3])
    else:
        with sqlite3.connect(f) as con:
            if damage == "other version":
                con.execute("UPDATE meta SET value = 'naseview.index/0' WHERE key = 'schema'")
            else:
                con.execute("UPDATE patients SET modified_ns = 'soon' WHERE id = 'P001'")
        con.close()
    assert _listing(r) == want


def test_a_hostile_index_cannot_open_outside_work(patient: Patient, tmp_path: Path):
    r = _two_patients(patient, tmp_path)
    _listing(r)
    secret = tmp_path / "secret"
    write_case_json(secret / "case", "secret")
    with sqlite3.connect(r.folders.index_file) as con:
        stamp = con.execute("SELECT stamp FROM patients WHERE id = 'P001'").fetchone()[0]
        for pid in ("../secret", str(secret), "P001/../../secret"):
            con.execute("INSERT INTO patients VALUES (?, ?, 'x', 'x', 9e18, 1, 1)",
                        (pid, stamp))
        con.execute("INSERT INTO simulations VALUES ('P001', '../../../secret/case', "
                    "'Evil', 'x', 9e18, NULL, NULL)")
    con.close()
    listed = r.list_patients()
    assert [p.patient_id for p in listed] == ["P002", "P001"]
    assert [s.slug for s in listed[1].simulations] == ["plan-a"]
    for pid in ("../secret", str(secret)):
        with pytest.raises(NaseviewError, match="not a patient folder name"):
            r.open_patient(pid)
    with pytest.raises(NaseviewError, match="not a simulation name"):
        r.load_simulation("P001", "../../../secret/case")


def test_a_locked_index_lists_the_folders(patient: Patient, tmp_path: Path, monkeypatch):
    r = _two_patients(patient, tmp_path)
    want = _listing(r)
    monkeypatch.setattr("naseview.records.index.BUSY_TIMEOUT_S", 0.05)
    other = sqlite3.connect(r.folders.index_file, isolation_level=None)
    try:
        other.execute("PRAGMA journal_mode = DELETE")   # no WAL: a writer blocks readers
        other.execute("BEGIN EXCLUSIVE")
        assert _listing(r) == want and r.index.last_source == "scan"
    finally:
        other.execute("ROLLBACK")
        other.close()
    assert _listing(r) == want and r.index.last_source in ("index", "rebuilt")
    assert r.folders.index_file.is_file()


def test_two_servers_share_one_work_folder(patient: Patient, tmp_path: Path):
    r = _two_patients(patient, tmp_path)
    s = PatientRecords(r.folders.root)
    assert _listing(r) == _listing(s)
    case = write_case_json(r.folders.case_dir("P003"), "P003")
    s.save_reconstruction("P003", grid_result(case))
    assert _listing(r)[0][:3] == ("P003", True, True)
    assert _listing(r) == _listing(s)
