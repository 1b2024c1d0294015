"""The app's measurements table shows radix height from a one-photo mf as an estimate with
its uncertainty, never as a plain finding; calliper inputs stay "input" (issue 23 item 5)."""

from __future__ import annotations

import re

import numpy as np

from naseview.app.export import measurements_markdown
from naseview.measurements import calliper_inputs, clinical_measurements, estimated_measurements

LM = {"g": np.array([0.0, 0.0, 0.0]), "n": np.array([0.0, -15.0, -3.0]),
      "prn": np.array([0.0, -45.0, 25.0]), "al_l": np.array([17.0, -48.0, 5.0]),
      "al_r": np.array([-17.0, -48.0, 5.0]),
      "mf_l": np.array([9.0, -14.0, -12.0]), "mf_r": np.array([-9.0, -14.0, -12.0])}


def _extra(sd_mf: float) -> dict:
    return {"landmark_uncertainty_mm": {k: 0.3 for k in LM} | {"mf_l": sd_mf, "mf_r": sd_mf},
            "landmarks_one_photo": {"mf_l": "line of sight", "mf_r": "line of sight"},
            "landmark_sight_direction": {"mf_l": [0.0, 0.0, -1.0], "mf_r": [0.0, 0.0, -1.0]}}


def _row(md: str, title: str) -> str:
    return next(line for line in md.splitlines() if line.startswith(f"| {title}"))


def test_radix_height_is_shown_estimated_when_mf_is_uncertain():
    m = clinical_measurements(LM)
    est = estimated_measurements(LM, _extra(3.8))
    md = measurements_markdown(m, m, "clinical", calliper_inputs(["al_l-al_r"]), est)
    sd = est["radix_height"].sd_mm
    v = m["radix_height"]
    assert _row(md, "Radix height") == (
        f"| Radix height *(estimated: mf seen in one photo)* | {v:.1f} ± {sd:.1f} | "
        f"{v:.1f} ± {sd:.1f} | +0.0 |")
    assert "*estimated*: ± one standard deviation" in md
    assert _row(md, "Nasal width").startswith("| Nasal width *(input)* |")   # unchanged
    assert "±" not in _row(md, "Radix level")                      # front rays: level exact


def test_radix_height_is_a_plain_finding_when_mf_is_certain():
    m = clinical_measurements(LM)
    est = estimated_measurements(LM, _extra(1.2))
    assert est == {}
    md = measurements_markdown(m, m, "clinical", (), est)
    row = _row(md, "Radix height")
    assert "estimated" not in row and "±" not in row
    assert re.fullmatch(r"\| Radix height \| -?\d+\.\d \| -?\d+\.\d \| \+0\.0 \|", row)
    assert "estimated" not in md
