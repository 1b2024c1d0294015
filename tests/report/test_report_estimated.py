"""Radix height from a one-photo mf is shown as an estimate with its uncertainty, never as
a plain finding, in the report's table (issue 23 item 5)."""

from __future__ import annotations

import html
import re

import numpy as np
import pytest
from test_report import height_field_face

from naseview.landmarks import ALL_IDS
from naseview.measurements import clinical_measurements, estimated_measurements
from naseview.reconstruction import Reconstruction
from naseview.report import ReportData, measurement_rows, report_html
from naseview.report.images import measurements_image
from naseview.report.sources import _estimated

ONE_PHOTO = {"mf_l": "line of sight", "mf_r": "line of sight"}


def _rec(lms: dict[str, np.ndarray], sd_mf: float) -> Reconstruction:
    """A reconstruction whose mf were clicked in the front photo only, placed on their
    front rays with ``sd_mf`` mm along them."""
    unc = {k: 0.3 for k in lms} | {"mf_l": sd_mf, "mf_r": sd_mf}
    return Reconstruction(landmarks=dict(lms), extra={
        "landmark_uncertainty_mm": unc, "landmarks_one_photo": dict(ONE_PHOTO),
        "landmark_sight_direction": {"mf_l": [0.0, 0.0, -1.0], "mf_r": [0.0, 0.0, -1.0]}})


@pytest.fixture(scope="module")
def face():
    V, F, nose, lms = height_field_face()
    n = lms["n"]
    lms = dict(lms, mf_l=n + np.array([9.0, 1.0, -9.0]), mf_r=n + np.array([-9.0, 1.0, -9.0]))
    return V, F, nose, lms


def _data(face, sd_mf: float) -> ReportData:
    V, F, nose, lms = face
    return ReportData("case-r", V, F, nose, clinical_measurements(lms), date="2025-01-02",
                      calliper={"al_l-al_r": 34.0}, estimated=_estimated(_rec(lms, sd_mf)))


def _radix_row(text: str) -> str:
    return re.search(r"<tr><td class='what'><b>Radix height</b>.*?</tr>", text).group(0)


def test_rows_mark_radix_height_estimated_only_when_uncertain(face):
    lms = face[3]
    m = clinical_measurements(lms)
    big = estimated_measurements(lms, _rec(lms, 3.8).extra)
    rows = {r["name"]: r for r in measurement_rows(m, None, ("al_l-al_r",), big)}
    r = rows["radix_height"]
    assert r["sd"] == pytest.approx(np.sqrt(0.09 + 3.8 ** 2 / 2))
    assert r["estimated"] == "mf seen in one photo"
    assert "the inner corners of the eye sockets show in one photo only" in r["estimate_note"]
    assert "radix_level" not in big and rows["radix_level"]["sd"] is None   # front rays
    assert rows["nasal_width"]["calliper"] and rows["nasal_width"]["sd"] is None
    small = estimated_measurements(lms, _rec(lms, 1.2).extra)
    rows = {r["name"]: r for r in measurement_rows(m, None, (), small)}
    assert rows["radix_height"]["sd"] is None and rows["radix_height"]["estimated"] == ""
    assert rows["radix_height"]["estimate_note"] == ""


def test_the_report_shows_the_estimate_with_its_uncertainty(face):
    data = _data(face, 3.8)
    text, images = report_html(data, render_size=64)
    row = html.unescape(_radix_row(text))
    v = data.measurements_before["radix_height"]
    sd = data.estimated["radix_height"].sd_mm
    assert f"{v:.1f} ± {sd:.1f} mm" in row
    assert (f"Estimated: the inner corners of the eye sockets show in one photo only, so "
            f"this value may be off by about {sd:.1f} mm either way.") in row
    patient = re.sub(r"<[^>]+>", " ", text.split("Technical appendix for your surgeon")[0])
    assert not [i for i in ALL_IDS if len(i) > 1 and re.search(rf"\b{i}\b", patient)]
    appendix = html.unescape(text.split("Technical appendix for your surgeon")[1])
    assert f"Estimated (mf seen in one photo): ± {sd:.1f} mm is one standard" in appendix
    assert "Nasal width" in text and "Calliper input of this case" in text  # unchanged
    assert images["measurements"].shape[1] == 900


def test_a_small_uncertainty_is_a_plain_finding(face):
    data = _data(face, 1.2)
    assert data.estimated == {}
    text, _ = report_html(data, render_size=64)
    row = html.unescape(_radix_row(text))
    assert "±" not in row and "Estimated" not in row
    assert f"{data.measurements_before['radix_height']:.1f} mm" in row


def test_the_image_table_says_estimated():
    lms = {"n": np.array([0.0, -15, -3]), "mf_l": np.array([9.0, -14, -12]),
           "mf_r": np.array([-9.0, -14, -12])}
    m = clinical_measurements(lms)
    est = estimated_measurements(lms, _rec(lms, 3.8).extra)
    rows = measurement_rows(m, None, (), est)
    img = measurements_image(rows)
    assert img.ndim == 3 and img.dtype == np.uint8
