"""Every measurement on two real face meshes (the ICT mean face, the demo reconstruction),
the measurement descriptions, and the calliper inputs."""

from __future__ import annotations

import re

import pytest
from helpers import demo_output_dir, ict_baseline

from naseview.editing.baseline import Baseline, baseline_from_output_dir
from naseview.landmarks import LANDMARK_IDS, TABLE1_DISTANCES
from naseview.measurements import MEASUREMENT_INFO, calliper_inputs, clinical_measurements

PLAUSIBLE: dict[str, tuple[float, float]] = {
    "nasal_length": (35, 60), "nasal_height": (40, 65), "nasofrontal_angle": (100, 160),
    "dorsal_hump_depth": (0, 6), "radix_height": (0, 15), "radix_level": (-8, 8),
    "nasolabial_angle": (80, 135), "tip_rotation": (85, 125), "tip_projection": (15, 40),
    "goode_ratio": (0.4, 0.75), "crumley_projection": (15, 40), "crumley_ratio": (0.4, 0.75),
    "crumley_height_ratio": (0.6, 1.0),
    "columellar_show": (-2, 10),            # at mid-columella; < 0: rim below the columella
    "nasal_width": (25, 45), "alar_base": (25, 45), "nasal_index": (50, 100),
    "intercanthal_width": (25, 45), "alar_intercanthal_ratio": (0.7, 1.5),
    "dorsal_deviation": (-3, 3), "tip_deviation": (-3, 3), "nostril_symmetry": (0.8, 1.0),
}
"""Broad adult bounds (not norms): a value outside is a wrong measurement, not a nose."""


def _demo() -> Baseline:
    """The demo case reconstructed (the default face model: ICT in the tests)."""
    return baseline_from_output_dir(demo_output_dir())


@pytest.mark.parametrize("face", ["ict", "demo"])
def test_real_faces_give_every_measurement_with_plausible_values(face: str) -> None:
    b = ict_baseline() if face == "ict" else _demo()
    m = clinical_measurements(b.landmarks, b.curves, b.V, b.F)
    assert list(m) == list(MEASUREMENT_INFO)           # all of them, in report order
    for name, (lo, hi) in PLAUSIBLE.items():
        assert lo <= m[name] <= hi, (name, m[name])
    for a, b_ in TABLE1_DISTANCES:
        assert 3.0 < m[f"{a}-{b_}"] < 60.0
    # the mesh is symmetric about the midline for the ICT mean face
    if face == "ict":
        assert abs(m["dorsal_deviation"]) < 0.3 and abs(m["tip_deviation"]) < 0.1
        assert m["nostril_symmetry"] > 0.99


def test_every_measurement_is_described_for_surgeon_and_patient() -> None:
    ids = set(LANDMARK_IDS)
    curve_names = {"mid", "bottom", "ala_l", "ala_r", "c", "sill_l", "sill_r", "side_l",
                   "side_r", "mesh"}
    for name, info in MEASUREMENT_INFO.items():
        assert info.name == name and info.unit in ("mm", "deg", "")
        assert info.title and info.description and info.plain.endswith(".")
        assert info.group in ("profile", "tip", "width", "symmetry", "distance")
        assert info.uses and set(info.uses) <= ids | curve_names, name
        words = set(re.findall(r"[a-z_]+", info.plain.lower()))
        assert not words & (ids - {"c", "g", "n", "r", "k"}), (name, info.plain)
        for rng in (info.normal, info.normal_female, info.normal_male):
            assert rng is None or rng[0] < rng[1]
        if info.normal is not None:
            assert info.source, name
    assert MEASUREMENT_INFO["nasolabial_angle"].normal_female is not None
    groups = [i.group for i in MEASUREMENT_INFO.values()]
    assert groups == sorted(groups, key=["profile", "tip", "width", "symmetry",
                                         "distance"].index)     # report order by group


def test_calliper_inputs_are_labelled_not_found() -> None:
    assert calliper_inputs(["al_l-al_r"]) == {"al_l-al_r", "nasal_width"}
    assert calliper_inputs(["ac_r-ac_l"]) == {"ac_l-ac_r", "alar_base"}
    assert calliper_inputs(["n-prn", "al_r-al_l"]) == {"n-prn", "nasal_length", "al_l-al_r",
                                                       "nasal_width"}
    assert calliper_inputs(iter(["n-sn"])) == {"n-sn", "nasal_height"}
    assert calliper_inputs(["mf_l-al_r"]) == {"mf_l-al_r"}        # a distance, no name
    assert calliper_inputs([]) == set()
    assert calliper_inputs(["junk", "n-n", "a-b-c", "al_l-xx"]) == set()
