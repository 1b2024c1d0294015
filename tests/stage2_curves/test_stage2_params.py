"""CurveParams: defaults and ranges checked at construction: stage2_curves.params."""

from __future__ import annotations

import pytest

from naseview.stage2_curves import CurveParams


def test_params_validate_and_default_to_55() -> None:
    assert CurveParams().total_sub_landmarks() == 55
    with pytest.raises(ValueError, match="closing_px"):
        CurveParams(closing_px=-1)
    with pytest.raises(ValueError, match="sub_landmarks"):
        CurveParams(sub_landmarks={"nose": 3})
