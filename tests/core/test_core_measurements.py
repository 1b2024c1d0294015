"""Clinical measurements on hand-made landmark sets (naseview.measurements): distances,
omission of missing inputs, the landmark-only profile."""

from __future__ import annotations

import numpy as np
import pytest

from naseview.landmarks import TABLE1_DISTANCES
from naseview.measurements import MEASUREMENT_INFO, clinical_measurements, format_measurements


def _nose() -> dict[str, np.ndarray]:
    """A simple nose in the SPEC frame (mm): g at the origin, dorsum straight."""
    P = {
        "g": (0, 0, 0), "n": (0, -15, -3), "prn": (0, -45, 25), "sn": (0, -55, 8),
        "c": (0, -50, 20), "k": (0, -25, 4), "r": (0, -32, 10),
        "al_l": (17, -48, 5), "al_r": (-17, -48, 5), "ac_l": (15, -50, 1),
        "ac_r": (-15, -50, 1), "mf_l": (9, -15, -8), "mf_r": (-9, -15, -8),
        "int_l": (10, -38, 8), "int_r": (-10, -38, 8), "alp_l": (8, -50, 14),
        "alp_r": (-8, -50, 14), "md_l": (5, -48, 20), "md_r": (-5, -48, 20),
    }
    return {k: np.array(v, float) for k, v in P.items()}


def test_distances_and_indices_have_the_right_values() -> None:
    lm = _nose()
    m = clinical_measurements(lm)
    for a, b in TABLE1_DISTANCES:
        assert m[f"{a}-{b}"] == pytest.approx(np.linalg.norm(lm[a] - lm[b]))
    assert m["mf_l-mf_r"] == pytest.approx(18.0)
    assert m["nasal_length"] == pytest.approx(np.hypot(30, 28))
    assert m["nasal_height"] == pytest.approx(np.hypot(40, 11))
    assert m["nasal_width"] == pytest.approx(34.0)
    assert m["alar_base"] == pytest.approx(30.0)
    assert m["nasal_index"] == pytest.approx(34.0 / np.hypot(40, 11) * 100)
    # Goode: prn is 24 mm anterior of ac; ratio to n-prn
    assert m["tip_projection"] == pytest.approx(24.0)
    assert m["goode_ratio"] == pytest.approx(24.0 / np.hypot(30, 28))
    assert set(m) <= set(MEASUREMENT_INFO)
    assert len(format_measurements(m)) == len(m)


def test_nasofrontal_angle() -> None:
    lm = {"g": np.zeros(3), "n": np.array([0, -10.0, 0]), "prn": np.array([0, -30.0, 0])}
    assert clinical_measurements(lm)["nasofrontal_angle"] == pytest.approx(180.0)
    lm["prn"] = np.array([0, -10.0, 20.0])
    assert clinical_measurements(lm)["nasofrontal_angle"] == pytest.approx(90.0)
    lm["prn"] = np.array([0, -20.0, 10.0])
    assert clinical_measurements(lm)["nasofrontal_angle"] == pytest.approx(135.0)


def test_missing_landmarks_omit_keys() -> None:
    lm = _nose()
    for k in ("ac_l", "ac_r", "sn"):
        del lm[k]
    m = clinical_measurements(lm)
    for key in ("alar_base", "nasal_height", "nasal_index", "tip_projection", "goode_ratio",
                "ac_l-ac_r", "int_l-ac_l", "c-sn", "tip_rotation", "nasolabial_angle",
                "crumley_ratio", "columellar_show", "intercanthal_width", "nostril_symmetry"):
        assert key not in m
    assert "nasal_width" in m and "nasofrontal_angle" in m
    assert clinical_measurements({}) == {}


def test_landmark_profile_gives_the_hump_of_k_and_r() -> None:
    """Without curves or mesh the profile is the polyline n-k-r-prn-c-sn: a kyphion 1.5 mm
    in front of the n-prn line is a 1.5 mm hump; k and r behind it, no hump."""
    lm = _nose()
    m = clinical_measurements(lm)
    assert m["dorsal_hump_depth"] == 0.0           # k, r of _nose() lie behind n-prn
    u = (lm["prn"] - lm["n"]) / np.linalg.norm(lm["prn"] - lm["n"])
    a = np.array([0.0, u[2], -u[1]])                # anterior normal of n-prn
    lm["k"] = lm["n"] + 0.4 * (lm["prn"] - lm["n"]) + 1.5 * a
    assert clinical_measurements(lm)["dorsal_hump_depth"] == pytest.approx(1.5)


def test_degenerate_input_omits_and_never_raises() -> None:
    same = {k: np.array([1.0, 2.0, 3.0]) for k in _nose()}
    m = clinical_measurements(same, curves={"mid": np.zeros((3, 3)), "sill_l": np.zeros((4, 3)),
                                            "sill_r": np.zeros((4, 3))},
                              V=np.zeros((3, 3)), F=np.array([[0, 1, 2]]))
    assert m["nasal_length"] == 0.0 and "nasal_index" not in m and "goode_ratio" not in m
    assert all(np.isfinite(v) for v in m.values())
    nan = dict(_nose(), prn=np.array([np.nan, 0.0, 0.0]))
    assert "nasal_length" not in clinical_measurements(nan)
    bad_faces = clinical_measurements(_nose(), V=np.zeros((3, 3)), F=np.array([[0, 1, 7]]))
    assert bad_faces == clinical_measurements(_nose())


def test_dorsal_hump_from_curve_and_from_mesh() -> None:
    lm = _nose()
    n, prn = lm["n"], lm["prn"]
    u = (prn - n) / np.linalg.norm(prn - n)
    a = np.array([0, 0, 1.0]) - u[2] * u
    a /= np.linalg.norm(a)
    s = np.linspace(0, 1, 41)
    bump = 3.0 * np.sin(np.pi * s) ** 2            # 3 mm hump at mid-dorsum
    dorsum = n + s[:, None] * (prn - n) + bump[:, None] * a
    mid = np.concatenate([[lm["g"]], dorsum, [lm["c"], lm["sn"]]])
    m = clinical_measurements(lm, curves={"mid": mid})
    assert m["dorsal_hump_depth"] == pytest.approx(3.0, abs=1e-6)
    # a concave (saddle) dorsum has no hump
    saddle = n + s[:, None] * (prn - n) - bump[:, None] * a
    m = clinical_measurements(lm, curves={"mid": np.concatenate([[lm["g"]], saddle])})
    assert m["dorsal_hump_depth"] == pytest.approx(0.0, abs=1e-9)
    # the same hump as a strip of triangles across the midline (no curve given)
    left = dorsum + np.array([4.0, 0, 0])
    right = dorsum - np.array([4.0, 0, 0])
    V = np.concatenate([left, right])
    k = len(dorsum)
    F = np.array([[i, i + 1, k + i] for i in range(k - 1)]
                 + [[i + 1, k + i + 1, k + i] for i in range(k - 1)])
    m = clinical_measurements(lm, V=V, F=F)
    assert m["dorsal_hump_depth"] == pytest.approx(3.0, abs=0.02)
