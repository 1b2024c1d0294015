"""The consultation report is written into the patient's own folder, or, for a case
that is not a patient (the demo, the ICT mean face), into ``WORK/.reports/<case id>``:
it never makes a patient folder (issue 27), and it is never written out of the work
folder through a symbolic link (the full report embeds the photos)."""

from __future__ import annotations

import pytest
from helpers import open_tab

from naseview.errors import NaseviewError
from naseview.intake.patients import PatientFolders


def test_report_of_a_case_that_is_no_patient_makes_no_patient(ict_app, tmp_path):
    server, app, tabs = ict_app
    tab, screen = open_tab(server, app)
    tabs.append(tab)
    assert not screen.patient.app.patient_id
    before = PatientFolders(app.work_dir).patient_ids()
    outside = tmp_path / "outside"
    outside.mkdir()
    loose = app.work_dir / ".reports"
    loose.mkdir(parents=True, exist_ok=True)
    (loose / "ict-mean").symlink_to(outside, target_is_directory=True)
    with pytest.raises(NaseviewError, match="symbolic link"):
        screen.patient.write_report(deidentified=False)
    assert list(outside.iterdir()) == []
    (loose / "ict-mean").unlink()
    path = screen.patient.write_report(deidentified=False)   # the real folder: written
    assert path.parent == loose / "ict-mean" and path.is_file()
    assert PatientFolders(app.work_dir).patient_ids() == before      # no new patient
    assert not (app.work_dir / "ict-mean").exists()
