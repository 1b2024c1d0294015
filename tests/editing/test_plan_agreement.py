"""Each manoeuvre moves the measurement it names by the amount typed (issue 27 item 3):
:data:`naseview.editing.manoeuvres.info.MEASURES`, checked with the app's solver on the
ICT mean face and on the demo reconstruction (``benchmarks/bench_plan.py`` prints the
whole table on the demo and james)."""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest
from helpers import demo_output_dir, ict_baseline

from naseview.editing.baseline import Baseline, baseline_from_output_dir
from naseview.editing.manoeuvres import MANOEUVRES
from naseview.editing.manoeuvres.info import MEASURES, expected_change
from naseview.editing.manoeuvres.plan import HUMP_MARGIN_MM
from naseview.editing.solver import NoseEditSolver
from naseview.measurements import clinical_measurements
from naseview.report.plan import plan_figures

FACES = ("ict", "demo")


@cache
def _solver(face: str) -> tuple[Baseline, NoseEditSolver]:
    b = ict_baseline() if face == "ict" else baseline_from_output_dir(demo_output_dir())
    return b, NoseEditSolver(b)


def _change(face: str, name: str, amount: float) -> tuple[float, tuple[str, ...]]:
    b, s = _solver(face)
    key = MEASURES[name][0]
    before = s(b.landmarks).measurements[key]
    out = s(b.landmarks, manoeuvres={name: amount})
    return out.measurements[key] - before, out.warnings


@pytest.mark.parametrize("face", FACES)
@pytest.mark.parametrize("name,amount", [("tip_rotation", 10.0), ("tip_rotation", 5.0),
                                         ("tip_rotation", -5.0),
                                         ("columella_setback", 2.0),
                                         ("tip_narrowing", 2.0),
                                         ("alar_base_narrowing", 3.0)])
def test_the_named_measurement_changes_by_the_amount(face, name, amount):
    got, _ = _change(face, name, amount)
    want = expected_change(name, amount)
    assert got == pytest.approx(want, rel=0.1, abs=0.1), (name, amount, got)


def test_every_manoeuvre_names_a_measurement_the_table_has():
    b, _ = _solver("ict")
    m = clinical_measurements(b.landmarks, b.curves, b.V, b.F)
    assert set(MEASURES) == set(MANOEUVRES)
    for name, (key, _) in MEASURES.items():
        assert key in m, name
        assert "-" not in key, name      # a named row of the table, not a Table 1 key


@pytest.mark.parametrize("face", FACES)
def test_a_hump_reduction_past_the_hump_is_capped_and_said(face):
    b, s = _solver(face)
    hump = s.plan.hump_depth
    assert hump is not None and hump > 0.5
    got, warnings = _change(face, "hump_reduction", hump + 1.5)
    assert any("straight" in w and "\n" not in w for w in warnings)
    assert got == pytest.approx(-hump, rel=0.1, abs=0.1)
    # no crease: the capped dorsum is the one at the cap, not lowered further
    D = s.plan.displacement({"hump_reduction": hump + 1.5})
    np.testing.assert_array_equal(D, s.plan.displacement(
        {"hump_reduction": hump + HUMP_MARGIN_MM}))


def test_the_alar_base_control_says_per_side():
    info = MANOEUVRES["alar_base_narrowing"]
    assert info.control_label == "Alar base narrowing (mm per side)"
    assert plan_figures({"alar_base_narrowing": 3.0}) == [("Alar base narrowing",
                                                           "3 mm per side")]
    assert MANOEUVRES["tip_rotation"].control_label == "Tip rotation (°)"


def test_a_hump_measured_in_the_supratip_is_said_to_sharpen_the_tip():
    for face, said in (("demo", True), ("ict", False)):
        b, s = _solver(face)
        warnings = s(b.landmarks, manoeuvres={"hump_reduction": 1.0}).warnings
        assert any("supratip" in w and "sharpens the tip" in w for w in warnings) == said, \
            (face, s.plan.hump_above_tip)
