"""The report reads as a patient document: plain words, usual ranges in grey without
flags, calliper inputs labelled as such, the plan in words and figures, the surgeon's
notes only (never machine text), surgeon / clinic / patient name in the full version
only, and clean grey nose renders in the de-identified version."""

from __future__ import annotations

import html
import importlib.util
import re
from types import SimpleNamespace

import cv2
import numpy as np
import pytest
from test_report import height_field_face

from naseview.camera import standard_camera
from naseview.landmarks import ALL_IDS
from naseview.measurements import clinical_measurements
from naseview.report import (
    DISCLAIMER,
    RENDER_VIEWS,
    ReportData,
    measurement_rows,
    plan_sentences,
    report_html,
    surgeon_notes,
)
from naseview.report.page import CALLIPER_NOTE
from naseview.report.table import usual_range_text
from naseview.report.views import NOSE_ONLY_FIELD, nose_vignette

SYNTH_NOTES = ("synthetic case: naseview synth --model generic --seed 7 --noise-px 1.5 "
               "--size 1024 --image-noise 2")
TYPED = "Wishes a straighter bridge; review the tip in 3 months."


@pytest.fixture(scope="module")
def data() -> ReportData:
    V, F, nose, lms = height_field_face()
    V2 = V.copy()
    w = np.exp(-np.sum((V - lms["prn"]) ** 2, axis=1) / (2 * 6.0**2))
    V2 += w[:, None] * np.array([0.0, 2.0, -2.0])
    lms2 = dict(lms, prn=lms["prn"] + np.array([0.0, 2.0, -2.0]))
    return ReportData("case-9", V, F, nose, clinical_measurements(lms), V2,
                      clinical_measurements(lms2), notes=TYPED, date="2025-01-02",
                      surgeon="Dr Ada Surgeon", clinic="Clinic Nord",
                      patient_name="Jane Q. Example", manoeuvres={"hump_reduction": 2.0},
                      calliper={"al_l-al_r": 37.4})


def _visible(text: str) -> str:
    """The words a reader sees (tags, styles and embedded images removed)."""
    text = re.sub(r"<style>.*?</style>|<[^>]+>", " ", text, flags=re.S)
    return html.unescape(text).replace("\xa0", " ")


def test_the_patient_pages_speak_plainly_without_flags_or_alarm_colours(data):
    text, _ = report_html(data, render_size=96)
    patient, appendix = text.split("Technical appendix for your surgeon")
    words = _visible(patient)
    ids = [i for i in ALL_IDS if len(i) > 1]                  # prn, al_l, mf_r...
    assert not [i for i in ids if re.search(rf"\b{i}\b", words)]
    for jargon in ("+z", "Table 1", "leptorrhine", "mesorrhine", "platyrrhine", "(high)",
                   "(low)", "paper"):
        assert jargon not in words, jargon
    assert not re.search(r"#e67e22|#b35900|#fff4e5|class='out'", text)  # no alarm colours
    assert f"<div class='calm'><strong>{DISCLAIMER}</strong>" in text
    assert "typically within about 1 mm" not in words
    assert "0.65-0.86 mm" in words and "1.6-2.2 mm" in words      # the real-scan figures
    rows = {r["name"]: r for r in measurement_rows(data.measurements_before)}
    nfa = rows["nasofrontal_angle"]
    assert nfa["plain"] and nfa["plain"] in words
    assert re.fullmatch(r"usual range \d+–\d+°", nfa["usual"]) and nfa["usual"] in words
    assert re.search(r"<td class='usual'>usual range \d+–\d+°</td>", text)   # grey
    assert "ac_l–ac_r" in _visible(appendix)                    # ids only for the surgeon


def test_usual_ranges_are_the_apps_and_by_sex_only_without_one():
    both = SimpleNamespace(unit="deg", normal=(90.0, 120.0), normal_female=(95.0, 110.0),
                           normal_male=(90.0, 95.0))
    assert usual_range_text(both) == "usual range 90–120°"     # the app's range (issue 27)
    by_sex = SimpleNamespace(unit="deg", normal=None, normal_female=(95.0, 110.0),
                             normal_male=(90.0, 95.0))
    assert usual_range_text(by_sex) == "women 95–110°, men 90–95°"
    assert usual_range_text(SimpleNamespace(unit="deg", normal=(115.0, 135.0))) == \
        "usual range 115–135°"
    assert usual_range_text(SimpleNamespace(unit="", normal=(0.55, 0.6))) == \
        "usual range 0.55–0.60"
    assert usual_range_text(SimpleNamespace(unit="mm", normal=None)) == ""


def test_a_calliper_distance_is_labelled_as_measured_at_the_visit(data):
    rows = {r["name"]: r for r in measurement_rows(data.measurements_before, None,
                                                   ("al_l-al_r",))}
    assert rows["nasal_width"]["calliper"] and not rows["nasal_length"]["calliper"]
    text, _ = report_html(data, render_size=96)
    row = re.search(r"<tr><td class='what'><b>Nasal width</b>.*?</tr>", text).group(0)
    assert CALLIPER_NOTE in row
    assert text.count(CALLIPER_NOTE) == 1
    plain, _ = report_html(ReportData(**{**vars(data), "calliper": {}}), render_size=96)
    assert CALLIPER_NOTE not in plain


def test_machine_notes_are_never_printed_and_the_surgeons_notes_are(data):
    assert surgeon_notes(SYNTH_NOTES) == "" and surgeon_notes("  ") == ""
    assert surgeon_notes("naseview reconstruct case -o out") == ""
    assert surgeon_notes(TYPED) == TYPED
    assert surgeon_notes("a 2-3 mm hump, non-smoker") == "a 2-3 mm hump, non-smoker"
    text, _ = report_html(data, render_size=96)
    assert "Notes from your surgeon" in text and TYPED in text
    synth, _ = report_html(ReportData(**{**vars(data), "notes": SYNTH_NOTES}),
                           render_size=96)
    assert "naseview synth" not in synth and "Notes from" not in synth
    anon, _ = report_html(data, deidentified=True, render_size=96)
    assert TYPED not in anon


def test_the_plan_is_given_in_words_and_figures(data):
    text, _ = report_html(data, render_size=96)
    words = _visible(text)
    if importlib.util.find_spec("naseview.editing.manoeuvres") is not None:
        from naseview.editing.manoeuvres import MANOEUVRES, describe_plan
        expected = describe_plan({"hump_reduction": 2.0})
        assert plan_sentences({"hump_reduction": 2.0, "tip_rotation": 0.0}) == expected
        assert expected and all(s in words for s in expected)
        assert f"({MANOEUVRES['hump_reduction'].title}, 2 mm)" in words
    else:                                                    # before the package lands
        assert "hump reduction: 2" in words
    assert words.index("What is planned") < words.index("Your measurements")
    none, _ = report_html(ReportData(**{**vars(data), "manoeuvres": {}}), render_size=96)
    assert "What is planned" not in none


def test_the_full_report_names_patient_surgeon_and_clinic_the_deidentified_none(data):
    text, _ = report_html(data, render_size=96)
    assert "<title>Nose consultation report — Jane Q. Example</title>" in text
    assert "Dr Ada Surgeon" in text and "Clinic Nord" in text and "2025-01-02" in text
    by_id, _ = report_html(ReportData(**{**vars(data), "patient_name": ""}),
                           render_size=96)
    assert "<title>Nose consultation report — case-9</title>" in by_id
    anon, _ = report_html(data, deidentified=True, render_size=96)
    for needle in ("Jane", "Example", "Ada", "Surgeon", "Clinic Nord", "case-9",
                   "2025-01-02", "Technical appendix"):
        assert needle not in anon, needle


def test_the_deidentified_renders_are_grey_noses_with_a_soft_clean_edge(data):
    _, imgs = report_html(data, deidentified=True, render_size=160)
    befores = imgs["views"][:, :160].astype(int)            # (the "after" has a blue line)
    assert int((befores.max(axis=2) - befores.min(axis=2)).max()) <= 2   # grey, no skin
    for k, view in enumerate(RENDER_VIEWS):
        before = imgs["views"][k * 160:(k + 1) * 160, :160]
        border = np.concatenate([before[:8].reshape(-1, 3), before[-8:].reshape(-1, 3),
                                 before[:, :8].reshape(-1, 3), before[:, -8:].reshape(-1, 3)])
        assert border.min() >= 240, view                    # no face outline at the frame
        assert before.min() < 200, view                     # the nose is there
    cam = standard_camera(data.V_before, "front", 160, data.nose_ids, NOSE_ONLY_FIELD)
    front = imgs["views"][:160, :160]
    for eye in ((-30.0, -5.0), (30.0, -5.0)):               # the eye holes: faded out
        x, y = (int(round(c)) for c in cam.project(np.array([[*eye, 0.0]]))[0])
        if 0 <= x < 160 and 0 <= y < 160:
            assert front[y, x].min() >= 250


def test_the_vignette_smooths_a_ragged_nose_region_into_a_clean_edge():
    yy, xx = np.mgrid[:200, :200]
    teeth = 6 * ((xx // 4) % 2) + 6 * ((yy // 4) % 2)       # a saw-tooth boundary
    ragged = (np.abs(xx - 100) < 40 + teeth) & (np.abs(yy - 100) < 60 + teeth)
    a = nose_vignette(ragged)
    assert a.min() == 0.0 and a.max() == pytest.approx(1.0)
    assert a[100, 100] == pytest.approx(1.0) and a[5, 5] == 0.0
    inner = (a > 0.5).astype(np.uint8)

    def perimeter(m: np.ndarray) -> float:
        cs, _ = cv2.findContours(m.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
        return sum(cv2.arcLength(c, True) for c in cs)

    assert perimeter(inner) < 0.75 * perimeter(ragged)       # the teeth are gone
    assert np.abs(np.diff(a, axis=1)).max() < 0.2            # a soft fade, no hard edge
