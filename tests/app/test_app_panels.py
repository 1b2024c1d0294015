"""The control panel: its parameter inputs are real fields of the stage params (an unknown
name fails loudly), and its photo flag rule."""

from __future__ import annotations

from dataclasses import fields
from types import SimpleNamespace

import pytest

from naseview.app import panels as panels_module
from naseview.app.guard import guarded_viser_server
from naseview.app.panels import (
    PHOTO_FLAG_FACTOR,
    PHOTO_FLAG_MIN_PX,
    STAGE2_FIELDS,
    STAGE3_FIELDS,
    Panels,
    flag_threshold,
)
from naseview.errors import NaseviewError
from naseview.stage1_landmarks import SfmParams
from naseview.stage2_curves import CurveParams
from naseview.stage3_mesh import RefineParams


def test_panel_fields_are_fields_of_the_stage_params():
    assert {n for n, _ in STAGE2_FIELDS} <= {f.name for f in fields(CurveParams)}
    assert {n for n, _ in STAGE3_FIELDS} <= {f.name for f in fields(RefineParams)}


def test_an_unknown_parameter_name_fails_loudly(monkeypatch):
    server = guarded_viser_server("127.0.0.1", 0, verbose=False)
    try:
        p = Panels(server, SimpleNamespace(params_changed=lambda stage: None))
        p.build_params(CurveParams(), RefineParams())
        assert set(p.params2) == {n for n, _ in STAGE2_FIELDS}
        assert set(p.params3) == {n for n, _ in STAGE3_FIELDS}
        monkeypatch.setattr(panels_module, "STAGE2_FIELDS",
                            STAGE2_FIELDS + (("path_min_edge", "min. edge strength"),))
        with pytest.raises(NaseviewError, match="path_min_edge"):
            p.build_params(CurveParams(), RefineParams())
    finally:
        server.stop()


def test_photo_flag_rule_is_the_panels_floor_and_stage_1s_factor():
    assert PHOTO_FLAG_FACTOR == SfmParams().suspect_factor
    assert flag_threshold({}) == PHOTO_FLAG_MIN_PX == 5.0
    assert flag_threshold({"front": {"g": 1.0, "n": 1.0}}) == 5.0
    assert flag_threshold({"front": {"g": 2.0, "n": 2.0}}) == 4.0 * 2.0
