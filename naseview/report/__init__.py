"""Consultation report: a patient document (self-contained HTML, PNGs, A4 PDF).

The report speaks plainly to the patient: the line :data:`DISCLAIMER` in a calm note,
the plan in words and figures (:mod:`naseview.report.plan`), the measurements with their
usual adult ranges in grey and no flags (:mod:`naseview.report.table`; calliper inputs
labelled as such), the accuracy of the method (:data:`ACCURACY_STATEMENT`), the photos,
and before / after side by side for the front, profile and base views, one printed A4
page per pair (:mod:`naseview.report.views`); then the surgeon's notes and a technical
appendix for the surgeon (the paper's landmark distances). Every image is embedded as a
base64 PNG (:mod:`naseview.report.images`), so the HTML file
(:mod:`naseview.report.page`) can be mailed or archived on its own; nothing is fetched
from the network; :func:`write_report_pdf` prints it to A4 with headless Chromium
(:mod:`naseview.report.pdf`). The data comes from a session file or ``naseview
reconstruct`` output (:mod:`naseview.report.sources`).

The de-identified version leaves out the photos, notes, names, case id, date, surgeon,
clinic and the technical appendix, and shows clean grey nose renders in a soft vignette
(no skin, no eyes, no face outline).

Example
-------
    data = report_data_from_session("session.json")
    write_report(data, "out/report.html")
    # -> PosixPath('out/report.html')
    write_report_pdf("out/report.html", "out/report.pdf")
    # -> PosixPath('out/report.pdf')
"""

from naseview.report.data import (
    ACCURACY_STATEMENT,
    DISCLAIMER,
    DISCLAIMER_DETAIL,
    ReportData,
    surgeon_notes,
)
from naseview.report.page import report_html, write_report
from naseview.report.pdf import write_report_pdf
from naseview.report.plan import plan_figures, plan_sentences
from naseview.report.sources import (
    report_command,
    report_data_from_output,
    report_data_from_session,
)
from naseview.report.table import MeasurementRow, measurement_rows
from naseview.report.views import RENDER_VIEWS, render_views

__all__ = ["ACCURACY_STATEMENT", "DISCLAIMER", "DISCLAIMER_DETAIL", "RENDER_VIEWS",
           "MeasurementRow", "ReportData", "measurement_rows", "plan_figures",
           "plan_sentences", "render_views", "report_command", "report_data_from_output",
           "report_data_from_session", "report_html", "surgeon_notes", "write_report",
           "write_report_pdf"]
