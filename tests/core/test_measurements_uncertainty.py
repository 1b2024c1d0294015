"""A measurement's uncertainty from its landmarks' stated uncertainties (issue 23 item 5)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from naseview.measurements import (
    ESTIMATED_SD_MM,
    clinical_measurements,
    estimated_measurements,
    format_measurements,
    measurement_uncertainty,
)

LM = {"g": np.array([0.0, 0.0, 0.0]), "n": np.array([0.0, -15.0, -3.0]),
      "mf_l": np.array([9.0, -14.0, -12.0]), "mf_r": np.array([-9.0, -14.0, -12.0])}
ONE_PHOTO = {"mf_l": "line of sight", "mf_r": "line of sight"}


def test_radix_sd_propagates_n_and_the_mean_of_mf():
    sd = measurement_uncertainty(LM, {"n": 0.3, "mf_l": 3.6, "mf_r": 4.2})
    want = math.sqrt(0.3 ** 2 + (3.6 ** 2 + 4.2 ** 2) / 4)
    assert sd["radix_height"] == pytest.approx(want)
    assert sd["radix_level"] == pytest.approx(want)       # no ray recorded: the bound


def test_a_ray_recorded_projects_the_sd_on_the_axis():
    # a front ray along -anterior: all of it in radix height, none in radix level
    d = {"mf_l": [0.0, 0.0, -2.0], "mf_r": [0.0, 0.0, -1.0]}
    sd = measurement_uncertainty(LM, {"n": 0.3, "mf_l": 3.6, "mf_r": 4.2}, d)
    assert sd["radix_height"] == pytest.approx(math.sqrt(0.09 + (3.6 ** 2 + 4.2 ** 2) / 4))
    assert sd["radix_level"] == pytest.approx(0.3)
    # a ray at 60 degrees from the anterior axis counts half
    c, s = 0.5, math.sqrt(3) / 2
    d60 = {"mf_l": [s, 0.0, c], "mf_r": [-s, 0.0, c]}
    sd = measurement_uncertainty(LM, {"mf_l": 4.0, "mf_r": 4.0}, d60)
    assert sd["radix_height"] == pytest.approx(math.sqrt((2.0 ** 2 + 2.0 ** 2) / 4))


def test_missing_inputs_give_no_entry():
    assert measurement_uncertainty({k: v for k, v in LM.items() if k != "mf_r"},
                                   {"n": 0.3, "mf_l": 3.6, "mf_r": 4.2}) == {}
    bad = dict(LM, n=np.array([np.nan, 0.0, 0.0]))
    assert measurement_uncertainty(bad, {"n": 0.3, "mf_l": 3.6, "mf_r": 4.2}) == {}
    assert measurement_uncertainty(LM, {}) == {}                        # nothing stated
    assert measurement_uncertainty(LM, {"mf_l": float("nan")}) == {}
    # one stated: the others count as exact
    assert measurement_uncertainty(LM, {"mf_l": 2.0})["radix_height"] == pytest.approx(1.0)


def test_estimated_above_one_mm_with_why():
    unc = {"n": 0.3, "g": 0.0, "mf_l": 3.6, "mf_r": 4.2}
    est = estimated_measurements(LM, {"landmark_uncertainty_mm": unc,
                                      "landmarks_one_photo": ONE_PHOTO})
    assert set(est) == {"radix_height", "radix_level"}
    e = est["radix_height"]
    assert e.sd_mm > ESTIMATED_SD_MM and e.points == ("mf",) and e.one_photo
    assert e.text(10.2) == f"10.2 ± {e.sd_mm:.1f} mm (estimated: mf seen in one photo)"
    # small one-photo uncertainty (1.2 mm per mf -> 0.9 mm): a plain finding
    small = {"n": 0.3, "mf_l": 1.2, "mf_r": 1.2}
    assert estimated_measurements(LM, {"landmark_uncertainty_mm": small,
                                       "landmarks_one_photo": ONE_PHOTO}) == {}
    # two-photo landmarks poorly determined: estimated, said so
    est = estimated_measurements(LM, {"landmark_uncertainty_mm": {"n": 2.5}})
    assert est["radix_height"].reason == "n poorly determined"
    assert estimated_measurements(LM, None) == {}
    assert estimated_measurements(LM, {"landmark_uncertainty_mm": "x"}) == {}


def test_format_measurements_carries_the_estimate():
    values = clinical_measurements(LM)
    est = estimated_measurements(LM, {"landmark_uncertainty_mm": {"mf_l": 3.6, "mf_r": 4.2},
                                      "landmarks_one_photo": ONE_PHOTO})
    line = next(s for s in format_measurements(values, est) if s.startswith("radix_height"))
    assert "± 2.77 (estimated: mf seen in one photo)" in line
    plain = next(s for s in format_measurements(values) if s.startswith("radix_height"))
    assert "±" not in plain and "estimated" not in plain
