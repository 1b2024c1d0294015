"""RefineParams: frozen, every field validated where it is made, one-line errors."""

from __future__ import annotations

import dataclasses

import pytest

from naseview.errors import NaseviewError
from naseview.stage3_mesh import RefineParams


def test_defaults_are_valid_frozen_and_changed_by_replace() -> None:
    p = RefineParams()
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.arap_iterations = 3  # type: ignore[misc]
    q = dataclasses.replace(p, arap_iterations=3, release_mm=float("inf"))
    assert q.arap_iterations == 3 and p.arap_iterations == 50


@pytest.mark.parametrize(("field", "value", "range_text"), [
    ("fit_sigma_mm", 0.0, "(0, 50]"),
    ("smooth_step", 1.5, "(0, 1]"),
    ("arap_iterations", -1, "[0, 10000]"),
    ("arap_iterations", 2.5, "[0, 10000]"),
    ("margin_mm", float("nan"), "(0, 20]"),
    ("n_modes", -2, "[0, 100000]"),
])
def test_out_of_range_names_field_and_range(field: str, value: object, range_text: str) -> None:
    with pytest.raises(NaseviewError) as e:
        RefineParams(**{field: value})
    msg = str(e.value)
    assert msg.startswith(f"RefineParams.{field}: ") and range_text in msg
    assert "\n" not in msg


def test_names_flags_and_unknown_fields() -> None:
    with pytest.raises(NaseviewError, match="sub_landmark_curves.*mid"):
        RefineParams(sub_landmark_curves=("mid", "nostril"))
    with pytest.raises(NaseviewError, match="handle_landmarks"):
        RefineParams(handle_landmarks=("prn", "tip"))
    with pytest.raises(NaseviewError, match="use_arap: 1 is not True or False"):
        RefineParams(use_arap=1)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="path_min_edge"):
        RefineParams(path_min_edge=1.0)  # type: ignore[call-arg]
    assert RefineParams(sub_landmark_curves=None, n_modes=None).n_modes is None


def test_mid_curve_handles_are_kept_with_a_model_that_cannot_reach_the_landmarks() -> None:
    """Automatic (None): hard mid-curve handles with fewer identity modes in the fit than
    landmarks (the generic face, 9), none with a richer model (ICT, 100); n_modes counts
    what the fit uses; an explicit choice wins."""
    auto = RefineParams()
    assert auto.mid_handles is None
    assert auto.keeps_mid_handles(9) and not auto.keeps_mid_handles(100)
    assert RefineParams(n_modes=9).keeps_mid_handles(100)
    assert not RefineParams(mid_handles=False).keeps_mid_handles(9)
    assert RefineParams(mid_handles=True).keeps_mid_handles(100)
    with pytest.raises(NaseviewError, match="mid_handles: 'yes' is not True or False"):
        RefineParams(mid_handles="yes")  # type: ignore[arg-type]
