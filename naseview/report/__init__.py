"""Consultation report: one self-contained HTML page plus PNG images.

The report shows the four photos, rendered views of the nose before and after the
simulation (front, profile, three-quarter, bottom; :mod:`naseview.report.views`), the
clinical measurements with their typical adult ranges (:mod:`naseview.report.table`) and,
prominently, the line :data:`DISCLAIMER`. Every image is embedded as a base64 PNG
(:mod:`naseview.report.images`), so the HTML file (:mod:`naseview.report.page`) can be
mailed or archived on its own; nothing is fetched from the network. The data comes from a
session file or ``naseview reconstruct`` output (:mod:`naseview.report.sources`).

The de-identified version leaves out the photos and the free-text notes and renders the
nose region only (no eyes, no face outline).

Example
-------
    data = report_data_from_session("session.json")
    write_report(data, "out/report.html")
    # -> PosixPath('out/report.html')
"""

from naseview.report.data import DISCLAIMER, DISCLAIMER_DETAIL, ReportData
from naseview.report.page import report_html, write_report
from naseview.report.sources import (
    report_command,
    report_data_from_output,
    report_data_from_session,
)
from naseview.report.table import MeasurementRow, measurement_rows
from naseview.report.views import RENDER_VIEWS, render_views

__all__ = ["DISCLAIMER", "DISCLAIMER_DETAIL", "RENDER_VIEWS", "MeasurementRow", "ReportData",
           "measurement_rows", "render_views", "report_command",
           "report_data_from_output", "report_data_from_session", "report_html",
           "write_report"]
