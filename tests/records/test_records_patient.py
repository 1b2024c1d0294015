"""The patient folder is the source of truth: a case opened from elsewhere is linked, never
copied or written; a reconstruction is kept with the case it was made from; ids and links
never lead out of the work folder."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from records_fixtures import grid_result, write_case_json

from naseview.editing.baseline import baseline_from_output_dir
from naseview.errors import NaseviewError
from naseview.records import PatientRecords


def _tree(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def test_a_case_from_elsewhere_is_linked_not_copied(tmp_path: Path):
    case = write_case_json(tmp_path / "cases" / "james-a", "james a")
    before = _tree(case)
    r = PatientRecords(tmp_path / "work")
    pid = r.patient_for_case(case)
    assert pid == "james-a" and r.patient_for_case(case) == pid      # found again
    saved = r.save_reconstruction(pid, grid_result(case))
    assert _tree(case) == before                         # nothing written into the case
    top = r.folders.patient_dir(pid)
    assert not (top / "case").exists()
    opened = r.open_patient(pid)
    assert opened.case_dir == case.resolve() and opened.problems == ()
    assert opened.reconstruction_dir == top / "reconstruction"
    assert opened.reconstruction_sha256 == saved.sha256 and opened.simulation is None
    assert baseline_from_output_dir(opened.reconstruction_dir).V.shape == (36, 3)

    # another case with the same id gets its own folder
    other = write_case_json(tmp_path / "other" / "james-a", "james a", note="other")
    assert r.patient_for_case(other) == "james-a-2"

    # the case is re-clicked: its reconstruction no longer matches, said in one line
    write_case_json(case, "james a", note="re-clicked")
    opened = r.open_patient(pid)
    assert opened.case_dir is None and len(opened.problems) == 1
    assert "patient.json: key 'case.sha256'" in opened.problems[0]
    assert r.patient_for_case(case) == pid                # opened again: the same patient
    opened = r.open_patient(pid)
    assert opened.case_dir == case.resolve() and opened.reconstruction_dir is None
    assert "key 'case_dir'" in opened.problems[0] and "\n" not in opened.problems[0]


def test_a_new_patients_case_and_reconstruction_stay_in_its_folder(tmp_path: Path):
    r = PatientRecords(tmp_path / "work")
    case = write_case_json(r.folders.case_dir("P7"), "P7")
    assert r.patient_for_case(case) == "P7"
    with pytest.raises(NaseviewError, match="not from the patient's case"):
        r.save_reconstruction("P7", grid_result(tmp_path / "somewhere-else"))
    assert not r.folders.reconstruction_dir("P7").exists()
    r.save_reconstruction("P7", grid_result(case))
    assert r.open_patient("P7").reconstruction_dir == r.folders.reconstruction_dir("P7")
    # the annotation that wrote the case may still rewrite it: the new folders are its own
    assert sorted(p.name for p in r.folders.patient_dir("P7").iterdir()) == [
        "case", "patient.json", "reconstruction"]


@pytest.mark.parametrize("bad", ["..", "../work", "a/b", "x\0y", "P" * 65, "", "in-progress",
                                 ".hidden", "index.sqlite"])
def test_hostile_ids_are_refused(tmp_path: Path, bad: str):
    r = PatientRecords(tmp_path / "work")
    with pytest.raises(NaseviewError, match="not a patient folder name") as e:
        r.open_patient(bad)
    assert "\n" not in str(e.value)


def test_a_symlink_inside_work_pointing_out_is_refused(tmp_path: Path):
    r = PatientRecords(tmp_path / "work")
    outside = tmp_path / "outside"
    write_case_json(outside / "case", "x")
    r.folders.root.mkdir(parents=True)
    os.symlink(outside, r.folders.root / "evil")           # a whole patient folder
    assert r.folders.patient_ids() == []
    with pytest.raises(NaseviewError, match="symbolic link"):
        r.open_patient("evil")
    real = write_case_json(r.folders.case_dir("P1"), "P1")
    r.save_reconstruction("P1", grid_result(real))
    sims = r.folders.simulations_dir("P1")
    os.symlink(outside, sims)                               # a folder inside a patient
    with pytest.raises(NaseviewError, match="symbolic link"):
        r.simulations("P1")
    assert r.open_patient("P1").simulations == ()
    assert list(outside.iterdir()) == [outside / "case"]   # nothing written out there
