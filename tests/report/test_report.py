"""The consultation report: a self-contained HTML page with the disclaimer, the
measurements and their ranges, renders before / after, and a de-identified version."""

from __future__ import annotations

import argparse
import base64
import html
import re
from pathlib import Path

import numpy as np
import pytest

from naseview.editing.baseline import Baseline, Solved
from naseview.editing.controller import EditController
from naseview.editing.session import save_session
from naseview.errors import NaseviewError
from naseview.measurements import MEASUREMENT_INFO, clinical_measurements
from naseview.report import (
    DISCLAIMER,
    ReportData,
    measurement_rows,
    report_command,
    report_html,
    write_report,
)
from naseview.report.table import format_range
from naseview.texture.bake import FaceTexture

NOTE = "follow-up in March; PRIVATE-NOTE-7731"


def height_field_face(n: int = 70) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
    """A face-like height field (mm, SPEC frame) with a nose ridge; a hole for each eye."""
    xs = np.linspace(-60, 60, n)
    ys = np.linspace(-100, 30, n)
    X, Y = np.meshgrid(xs, ys)
    Z = -0.006 * X**2 - 0.002 * (Y + 35) ** 2
    ridge = np.exp(-X**2 / (2 * 7.0**2)) * np.clip((-Y - 8) / 40.0, 0, 1) * 20.0
    ridge *= np.exp(-np.clip(-Y - 50, 0, None) ** 2 / 30.0)
    Z = Z + ridge
    V = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1], idx[:-1, 1:], idx[1:, :-1], idx[1:, 1:]
    F = np.vstack([np.column_stack([a.ravel(), c.ravel(), b.ravel()]),
                   np.column_stack([b.ravel(), c.ravel(), d.ravel()])])
    eye = np.zeros(len(V), bool)
    for ex in (-30.0, 30.0):
        eye |= (np.abs(V[:, 0] - ex) < 9) & (np.abs(V[:, 1] + 5) < 4)
    F = F[~eye[F].any(axis=1)]
    nose = np.flatnonzero((np.abs(V[:, 0]) < 22) & (V[:, 1] < -5) & (V[:, 1] > -62))

    def at(x: float, y: float) -> np.ndarray:
        return V[int(np.argmin((V[:, 0] - x) ** 2 + (V[:, 1] - y) ** 2))]

    lms = {"g": at(0, 0), "n": at(0, -10), "prn": at(0, -48), "sn": at(0, -60),
           "al_l": at(17, -48), "al_r": at(-17, -48), "ac_l": at(15, -52),
           "ac_r": at(-15, -52)}
    return V, F, nose, lms


@pytest.fixture(scope="module")
def data() -> ReportData:
    V, F, nose, lms = height_field_face()
    before = clinical_measurements(lms)
    V2 = V.copy()
    w = np.exp(-np.sum((V - lms["prn"]) ** 2, axis=1) / (2 * 6.0**2))
    V2 += w[:, None] * np.array([0.0, 3.0, -3.0])
    lms2 = dict(lms, prn=lms["prn"] + np.array([0.0, 3.0, -3.0]))
    after = clinical_measurements(lms2)
    rng = np.random.default_rng(1)
    photos = {v: rng.integers(0, 255, (90, 120, 3)).astype(np.uint8)
              for v in ("front", "left", "right", "bottom")}
    return ReportData("case-42", V, F, nose, before, V2, after, photos, notes=NOTE,
                      credit="test mesh", date="2025-01-02")


def images_of(text: str) -> list[bytes]:
    srcs = re.findall(r"<img[^>]*\ssrc='([^']*)'", text)
    out = []
    for s in srcs:
        assert s.startswith("data:image/png;base64,"), s[:40]
        png = base64.b64decode(s.split(",", 1)[1], validate=True)
        assert png[:8] == b"\x89PNG\r\n\x1a\n"
        out.append(png)
    return out


def test_html_is_self_contained_with_disclaimer_and_measurements(data, tmp_path: Path):
    path = write_report(data, tmp_path / "report.html", render_size=160)
    text = path.read_text(encoding="utf-8")
    assert DISCLAIMER == "A simulation is not a promised outcome."
    assert DISCLAIMER in text
    # nothing to fetch: no scripts, stylesheets, fonts or remote URLs
    assert not re.search(r"<script|<link|@import|url\(|src=['\"]https?:|href=['\"]https?:",
                         text, re.I)
    imgs = images_of(text)
    assert len(imgs) == 4 + 3 + 3        # photos, renders before, renders after
    # measurements with values, change and typical ranges
    rows = {r["name"]: r for r in measurement_rows(data.measurements_before,
                                                    data.measurements_after)}
    for name in ("nasal_length", "nasal_width", "nasofrontal_angle", "goode_ratio"):
        assert name in rows and f"<b>{rows[name]['title']}</b>" in text
    ranged = [r for r in rows.values() if MEASUREMENT_INFO[r["name"]].normal]
    assert ranged
    shown = html.unescape(text).replace("\xa0", " ")
    for r in ranged:                                                # usual ranges shown
        assert format_range(MEASUREMENT_INFO[r["name"]].normal, r["unit"]) in shown
    nl = rows["nasal_length"]
    assert f"{nl['before']:.1f} mm" in text and f"{nl['after']:.1f} mm" in text
    assert f"{nl['after'] - nl['before']:+.1f} mm" in text
    assert abs(nl["change"]) > 0.5                                  # the tip moved
    groups = [r["group"] for r in measurement_rows(data.measurements_before)]
    assert groups == sorted(groups)       # clinical measurements first, Table 1 after
    assert text.index("<h2>Your measurements</h2>") < text.index("Technical appendix")
    assert NOTE in text and "case-42" in text
    for name in ("views", "measurements", "photos"):
        assert (tmp_path / f"report-{name}.png").read_bytes()[:4] == b"\x89PNG"
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]


def test_renders_show_the_simulated_change(data):
    _, imgs = report_html(data, render_size=160)
    sheet = imgs["views"]
    assert sheet.shape == (3 * 160, 2 * 160, 3)                      # a row per view
    before, after = sheet[:, :160].astype(int), sheet[:, 160:].astype(int)
    assert before.std() > 10                                         # not blank
    assert np.abs(before - after).mean() > 0.5                       # the nose changed


def test_deidentified_version_has_no_photo_and_no_notes(data, tmp_path: Path):
    path = write_report(data, tmp_path / "anon.html", deidentified=True, render_size=160)
    text = path.read_text(encoding="utf-8")
    assert DISCLAIMER in text and "de-identified" in text
    assert len(images_of(text)) == 6                                 # renders only
    assert "photo" not in " ".join(re.findall(r"alt='([^']*)'", text))
    assert NOTE not in text and "PRIVATE-NOTE" not in text
    assert not (tmp_path / "anon-photos.png").exists()
    assert (tmp_path / "anon-views.png").exists()
    full = write_report(data, tmp_path / "full.html", render_size=160).read_text()
    photo_srcs = re.findall(r"alt='\w+ photo' src='([^']*)'", full)
    assert len(photo_srcs) == 4 and not any(s in text for s in photo_srcs)


def test_before_only_report_and_bad_name(data, tmp_path: Path):
    only = ReportData(data.case_id, data.V_before, data.F, data.nose_ids,
                      data.measurements_before)
    text, imgs = report_html(only, render_size=120)
    assert len(images_of(text)) == 3 and "<th>After</th>" not in text
    assert imgs["views"].shape[:2] == (3 * 120, 120)
    with pytest.raises(NaseviewError, match=r"\.html"):
        write_report(only, tmp_path / "report.pdf")


def test_report_command_from_a_session_file(data, tmp_path: Path):
    V, F, nose, lms = height_field_face()
    base = Baseline(V, F, nose, lms, measurements=clinical_measurements(lms))

    def solver(landmarks, interactive=False, **kwargs):
        Vn = V.copy()
        d = np.asarray(landmarks["prn"]) - lms["prn"]
        w = np.exp(-np.sum((V - lms["prn"]) ** 2, axis=1) / 72.0)
        Vn += w[:, None] * d
        return Solved(Vn, {}, np.zeros((0, 3)), clinical_measurements(landmarks))

    ctl = EditController(base, solver)
    try:
        ctl.move_landmarks({"prn": lms["prn"] + np.array([0.0, 2.0, -2.0])})
        ctl.set_manoeuvres({"hump_reduction": 1.5})
        assert ctl.wait_idle(20)
        save_session(tmp_path / "s.json", ctl, {"case_id": "case-77"})
    finally:
        ctl.close()
    args = argparse.Namespace(path=tmp_path / "s.json", output=tmp_path / "r.html",
                              deidentified=False, case=None)
    assert report_command(args) == 0
    text = (tmp_path / "r.html").read_text()
    assert "case-77" in text and "<th>After</th>" in text and DISCLAIMER in text
    assert "Lower the bump on the bridge of the nose by 1.5 mm" in text   # the plan
    with pytest.raises(NaseviewError, match="session file"):
        report_command(argparse.Namespace(path=tmp_path, output=None, deidentified=False,
                                          case=None))


def _green_skin(V: np.ndarray) -> FaceTexture:
    """A texture of one unmistakable colour (pure green) over the whole chart."""
    uv = (V[:, :2] - V[:, :2].min(axis=0)) / np.ptp(V[:, :2], axis=0)
    image = np.zeros((32, 32, 3), np.uint8)
    image[:, :, 1] = 255
    return FaceTexture(uv=uv, image=image, coverage=np.ones((32, 32), bool),
                       vertex_colors=np.tile(np.array([0, 255, 0], np.uint8), (len(V), 1)))


def _green_share(img_bgr: np.ndarray) -> float:
    b, g, r = (img_bgr[:, :, i].astype(int) for i in range(3))
    return float(np.mean((g > 120) & (g > r + 60) & (g > b + 60)))


def test_renders_show_the_patient_skin_but_never_in_the_deidentified_report(data):
    """The report's face is the patient's own (the texture baked from the photos); the
    de-identified version keeps plain nose renders, since skin identifies a person."""
    skinned = ReportData(**{**vars(data), "texture": _green_skin(data.V_before)})
    _, plain = report_html(data, render_size=120)
    _, textured = report_html(skinned, render_size=120)
    _, anon = report_html(skinned, deidentified=True, render_size=120)
    assert _green_share(plain["views"]) == 0.0
    assert _green_share(textured["views"]) > 0.2               # before and after, skinned
    assert _green_share(textured["views"][:, 120:]) > 0.1      # the simulated face too
    assert _green_share(anon["views"]) == 0.0
