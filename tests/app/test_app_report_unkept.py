"""Issue 26, item 3 (and issue 27, item 5): the report of a case that is not kept (a
session or baseline opened directly, the demo) never overwrites another patient's report
and makes no patient folder: it goes to ``WORK/.reports/<case id>/``."""

from __future__ import annotations

from helpers import open_tab


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
    before = sorted(p.name for p in app.work_dir.iterdir())
    path = screen.patient.write_report(deidentified=False)
    assert theirs.read_text() == "the other patient's report"
    assert path.parent == app.work_dir / ".reports" / "ict-mean" and path.is_file()
    assert sorted(p.name for p in app.work_dir.iterdir()) == sorted({*before, ".reports"})
