"""SfmParams: frozen, every field checked where it is made, one-line errors with the range."""

from __future__ import annotations

import dataclasses

import pytest

from naseview.errors import NaseviewError
from naseview.stage1_landmarks import SfmParams


def test_defaults_are_valid_frozen_and_changed_by_replace() -> None:
    p = SfmParams()
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.loss_scale_px = 2.0  # type: ignore[misc]
    q = dataclasses.replace(p, loss_scale_px=2.0, rig_yaw_deg=-p.rig_yaw_deg)
    assert (q.loss_scale_px, q.rig_yaw_deg, p.loss_scale_px) == (2.0, -90.0, 3.0)


@pytest.mark.parametrize(("field", "value", "range_text"), [
    ("loss_scale_px", 0.0, "(0, 100]"),
    ("max_iterations", 0, "[1, 100000]"),
    ("max_iterations", 2.5, "[1, 100000]"),
    ("resection_rounds", -1, "[0, 100]"),
    ("focal_coupling", -0.1, "[0, 10]"),
    ("tolerance", float("nan"), "(0, 1)"),
    ("max_focal_factor", 0.25, "(0.25, 1000]"),
    ("max_suspect_fraction", 1.5, "[0, 1]"),
    ("symmetry_sd_mm", 0.0, "(0, 100]"),
    ("rig_yaw_deg", 270.0, "[-180, 180]"),
])
def test_out_of_range_names_field_and_range(field: str, value: object, range_text: str) -> None:
    with pytest.raises(NaseviewError) as e:
        SfmParams(**{field: value})  # type: ignore[arg-type]
    msg = str(e.value)
    assert msg.startswith(f"SfmParams.{field}: ") and range_text in msg
    assert "\n" not in msg


def test_choices_flags_and_unknown_fields() -> None:
    with pytest.raises(NaseviewError, match=r"^SfmParams\.loss: 'l2' is not one of .*'huber'"):
        SfmParams(loss="l2")
    with pytest.raises(NaseviewError, match=r"^SfmParams\.tr_solver: "):
        SfmParams(tr_solver="dense")
    with pytest.raises(NaseviewError, match=r"^SfmParams\.drop_suspects: 1 is not True or False"):
        SfmParams(drop_suspects=1)  # type: ignore[arg-type]
    with pytest.raises(TypeError):
        SfmParams(huber_px=2.0)  # type: ignore[call-arg]
