"""Stage 3: where a sub-landmark sits on a mesh curve (naseview.stage3_mesh.curve_fractions).

Uses the ICT Face Model Light from ../shared (tests/conftest.py).
"""

from __future__ import annotations

import numpy as np
import pytest

from naseview.facemodel import load_face_model
from naseview.stage3_mesh.curve_fractions import arclength_point, curve_path_segment


@pytest.fixture(scope="module")
def ict_model():
    return load_face_model("ict")


def test_arclength_point_and_segments() -> None:
    P = np.array([[0, 0, 0], [1, 0, 0], [3, 0, 0.0]])
    assert arclength_point(P, 0.5) == (1, 2, pytest.approx(0.25))
    assert arclength_point(P, 0.0)[2] == 0.0 and arclength_point(P, 1.0)[:2] == (1, 2)


def test_sublandmark_correspondence_follows_the_mesh_curve(ict_model) -> None:
    m = ict_model
    path = curve_path_segment(m.curve_vertices["mid"], m, "mid", ("n", "prn"))
    assert path[0] == m.landmark_vertices["n"] and path[-1] == m.landmark_vertices["prn"]
    loop = curve_path_segment(m.curve_vertices["sill_l"], m, "sill_l", ("alpp_l", "alpp_l"))
    assert loop[0] == loop[-1] == m.landmark_vertices["alpp_l"]
