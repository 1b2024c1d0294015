"""The pipeline's typed stage contracts: PipelineParams takes each stage's own params type,
checked once at the boundary, with the field name in the one-line message."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

import naseview
from naseview.errors import NaseviewError
from naseview.pipeline import PipelineParams, parse_stages
from naseview.stage1_landmarks import SfmParams
from naseview.stage2_curves import CurveParams
from naseview.stage3_mesh import RefineParams
from naseview.stages import STAGE_NAMES, STAGE_TITLES


def test_defaults_and_stage_params_are_accepted() -> None:
    p = PipelineParams()
    assert isinstance(p.sfm, SfmParams) and p.curves is None and p.refine is None
    q = PipelineParams(sfm=SfmParams(), curves=CurveParams(), refine=RefineParams())
    assert isinstance(q.curves, CurveParams) and isinstance(q.refine, RefineParams)
    assert dataclasses.replace(p, curves=CurveParams()).curves == CurveParams()


@pytest.mark.parametrize("field, value", [("sfm", None), ("curves", {"closing_px": 3}),
                                          ("refine", CurveParams())])
def test_wrong_params_type_names_the_field(field: str, value: object) -> None:
    with pytest.raises(NaseviewError, match=rf"^PipelineParams\.{field}: ") as e:
        PipelineParams(**{field: value})  # type: ignore[arg-type]
    assert "\n" not in str(e.value)


def test_params_are_frozen_and_unknown_names_fail() -> None:
    with pytest.raises(dataclasses.FrozenInstanceError):
        PipelineParams().curves = CurveParams()  # type: ignore[misc]
    with pytest.raises(TypeError):
        PipelineParams(mesh=RefineParams())  # type: ignore[call-arg]


def test_stage_names_match_the_stage_folders() -> None:
    assert STAGE_NAMES == {1: "landmarks", 2: "curves", 3: "mesh"}
    package = Path(naseview.__file__).parent
    assert all((package / f"stage{n}_{name}").is_dir() for n, name in STAGE_NAMES.items())
    assert STAGE_TITLES == {1: "stage 1 — landmarks (paper §3.2)",
                            2: "stage 2 — curves (paper §3.3)", 3: "stage 3 — mesh (paper §3.4)"}
    assert parse_stages("3, 1") == (1, 3)
    with pytest.raises(NaseviewError, match=r"1 \(landmarks\), 2 \(curves\), 3 \(mesh\)"):
        parse_stages("2,3")
