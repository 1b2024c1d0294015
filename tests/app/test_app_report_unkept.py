"""Issue 26, item 3: the report of a case that is not kept (a session or baseline opened
directly) never overwrites another patient's report: it goes to ``WORK/<case id>`` only
when that folder is not a patient's."""

from __future__ import annotations

from pathlib import Path

from helpers import open_tab

from naseview.intake.patients import PatientFolders


def test_an_unkept_report_never_replaces_a_patients_report(ict_app):
    server, app, tabs = ict_app
    tab, screen = open_tab(server, app)
    tabs.append(tab)
    assert app.work.patient_id is None            # opened directly: not kept
    patient = app.work_dir / "ict-mean"           # a patient with the same case id
    (patient / "case").mkdir(parents=True)
    (patient / "case" / "case.json").write_text("{}")
    (patient / "report").mkdir()
    theirs = patient / "report" / "report.html"
    theirs.write_text("the other patient's report")
    path = screen.patient.write_report(deidentified=False)
    assert theirs.read_text() == "the other patient's report"
    assert path.parent == app.work_dir / "ict-mean-2" / "report" and path.is_file()
    again = screen.patient.write_report(deidentified=False)    # the same folder again
    assert again == path


def test_unkept_report_folders(tmp_path: Path):
    work = PatientFolders(tmp_path / "work")
    assert work.unkept_report_dir("P002") == work.report_dir("P002")       # free
    work.report_dir("P002").mkdir(parents=True)                            # only reports
    assert work.unkept_report_dir("P002") == work.report_dir("P002")
    (work.patient_dir("P002") / "simulations").mkdir()                     # a patient
    assert work.unkept_report_dir("P002") == work.report_dir("P002-2")
    (tmp_path / "work" / "P003").write_text("a file")                      # not a folder
    assert work.unkept_report_dir("P003") == work.report_dir("P003-2")
    assert work.unkept_report_dir("../x") == work.report_dir("x")
