"""The manoeuvre catalogue: names, ranges, amount checks and the patient's words."""

from __future__ import annotations

import math

import pytest

from naseview.editing.manoeuvres import MANOEUVRES, check_amounts, describe_plan
from naseview.errors import NaseviewError


def test_catalogue_lists_the_seven_manoeuvres_with_sane_ranges():
    assert list(MANOEUVRES) == ["hump_reduction", "radix_augmentation", "tip_projection",
                                "tip_rotation", "tip_narrowing", "alar_base_narrowing",
                                "columella_setback"]
    for name, m in MANOEUVRES.items():
        assert m.name == name and m.unit in ("mm", "deg")
        assert m.low <= 0.0 < m.high and m.step > 0
        assert "{amount}" in m.plain and m.definition and m.title
    assert MANOEUVRES["tip_rotation"].unit == "deg"
    assert (MANOEUVRES["hump_reduction"].low, MANOEUVRES["hump_reduction"].high) == (0, 5)


def test_check_amounts_returns_floats_and_drops_zeros():
    got = check_amounts({"hump_reduction": 2, "tip_rotation": -10, "tip_narrowing": 0.0})
    assert got == {"hump_reduction": 2.0, "tip_rotation": -10.0}
    assert all(type(v) is float for v in got.values())
    assert check_amounts({}) == {}


@pytest.mark.parametrize("amounts, words", [
    ({"hump_reduktion": 1.0}, "unknown manoeuvre 'hump_reduktion'"),
    ({"tip_projection": "2"}, "'tip_projection': expected a number in -4..4 mm"),
    ({"tip_projection": True}, "'tip_projection': expected a number"),
    ({"tip_rotation": math.nan}, "'tip_rotation': amount nan is not finite"),
    ({"tip_rotation": math.inf}, "'tip_rotation': amount inf is not finite"),
    ({"hump_reduction": 5.5}, "'hump_reduction': 5.5 mm is outside the allowed range 0..5 mm"),
    ({"radix_augmentation": -2.5}, "'radix_augmentation': -2.5 mm is outside"),
    ([("tip_projection", 1.0)], "expected an object of manoeuvre name -> amount"),
])
def test_check_amounts_rejects_bad_input_with_one_line_naming_the_key(amounts, words):
    with pytest.raises(NaseviewError) as err:
        check_amounts(amounts, "session.json: key 'manoeuvres'")
    msg = str(err.value)
    assert msg.startswith("session.json: key 'manoeuvres': ") and words in msg
    assert "\n" not in msg


def test_describe_plan_speaks_to_the_patient_in_display_order():
    lines = describe_plan({"tip_rotation": 5.0, "hump_reduction": 2.0, "tip_narrowing": 0.0,
                           "radix_augmentation": -1.5})
    assert lines == ["Lower the bump on the bridge of the nose by 2 mm",
                     "Deepen the top of the nose between the eyes by 1.5 mm",
                     "Turn the tip of the nose upwards by 5 degrees"]
    assert describe_plan({}) == []
