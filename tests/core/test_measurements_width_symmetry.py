"""Widths and symmetry on synthetic meshes and curves with known answers: intercanthal
width from eye holes, dorsal deviation of a shifted ridge, nostril areas."""

from __future__ import annotations

import numpy as np
import pytest

from naseview.measurements import clinical_measurements


def _grid(xs: np.ndarray, ys: np.ndarray, z: np.ndarray,
          hole: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Quad grid (two triangles per cell, counter-clockwise from +z) of heights ``z``
    (len(ys), len(xs)); cells where ``hole`` (len(ys)-1, len(xs)-1) is True are left out."""
    X, Y = np.meshgrid(xs, ys)
    V = np.stack([X.ravel(), Y.ravel(), z.ravel()], axis=1)
    nx = len(xs)
    F = []
    for j in range(len(ys) - 1):
        for i in range(nx - 1):
            if hole is not None and hole[j, i]:
                continue
            a, b, c, d = j * nx + i, j * nx + i + 1, (j + 1) * nx + i, (j + 1) * nx + i + 1
            F += [[a, b, d], [a, d, c]]
    return V, np.array(F)


LM = {"g": np.zeros(3), "n": np.array([0.0, -15, -3]), "prn": np.array([0.0, -45, 25]),
      "al_l": np.array([17.0, -48, 5]), "al_r": np.array([-17.0, -48, 5]),
      "mf_l": np.array([9.0, -15, -8]), "mf_r": np.array([-9.0, -15, -8])}


def test_intercanthal_width_from_two_eye_holes() -> None:
    xs, ys = np.arange(-50.0, 51.0, 2.0), np.arange(-60.0, 11.0, 2.0)
    cx, cy = 0.5 * (xs[:-1] + xs[1:]), 0.5 * (ys[:-1] + ys[1:])
    CX, CY = np.meshgrid(cx, cy)
    eyes = (np.abs(CX) > 15.0) & (np.abs(CX) < 40.0) & (CY > -26.0) & (CY < -14.0)
    V, F = _grid(xs, ys, np.full((len(ys), len(xs)), -10.0), eyes)
    m = clinical_measurements(LM, V=V, F=F)
    assert m["intercanthal_width"] == pytest.approx(32.0)   # holes start at |x| = 16
    assert m["alar_intercanthal_ratio"] == pytest.approx(34.0 / 32.0)
    # no eye openings (a closed plate): omitted, never guessed
    m = clinical_measurements(LM, V=V, F=_grid(xs, ys, V[:, 2].reshape(len(ys), -1))[1])
    assert "intercanthal_width" not in m and "alar_intercanthal_ratio" not in m


def _nose_mesh(shift: float) -> tuple[np.ndarray, np.ndarray]:
    """A ridge t = 20 - (x - shift)^2 / 8 (mm) between y = -47 and -13, sampled on a 1 mm
    grid: a dorsum displaced ``shift`` mm towards the subject's left."""
    xs, ys = np.arange(-16.0, 16.5, 1.0), np.arange(-47.0, -12.5, 1.0)
    X, _ = np.meshgrid(xs, ys)
    return _grid(xs, ys, 20.0 - (X - shift) ** 2 / 8.0)


def test_dorsal_deviation_of_a_shifted_ridge() -> None:
    V, F = _nose_mesh(0.0)
    assert clinical_measurements(LM, V=V, F=F)["dorsal_deviation"] == pytest.approx(0.0, abs=0.05)
    V, F = _nose_mesh(2.3)
    m = clinical_measurements(LM, V=V, F=F)
    assert m["dorsal_deviation"] == pytest.approx(2.3, abs=0.1)
    V, F = _nose_mesh(-1.7)
    assert clinical_measurements(LM, V=V, F=F)["dorsal_deviation"] == \
        pytest.approx(-1.7, abs=0.1)
    # the tip: prn 3 mm to the subject's right of the plane through g normal to mf_l - mf_r
    lm = dict(LM, prn=np.array([-3.0, -45, 25]))
    assert clinical_measurements(lm)["tip_deviation"] == pytest.approx(-3.0)
    # without a mesh: the mid-curve points between n and prn
    mid = np.array([[0.0, 0, 0], [0.0, -15, -3], [1.2, -30, 10], [0.0, -45, 25]])
    assert clinical_measurements(LM, curves={"mid": mid})["dorsal_deviation"] == \
        pytest.approx(1.2)


def _ellipse(x0: float, a: float, b: float, k: int = 240) -> np.ndarray:
    """Closed ellipse outline (k, 3) with half-axes a (along x), b (along z), in the plane
    y = -55 tilted 15 deg about x (a base plane not parallel to any axis plane)."""
    t = np.linspace(0, 2 * np.pi, k, endpoint=False)
    P = np.stack([x0 + a * np.cos(t), np.zeros_like(t), b * np.sin(t)], axis=1)
    c, s = np.cos(np.radians(15)), np.sin(np.radians(15))
    return P @ np.array([[1, 0, 0], [0, c, s], [0, -s, c]]).T + [0.0, -55.0, 10.0]


def test_nostril_symmetry_is_the_area_ratio() -> None:
    curves = {"sill_l": _ellipse(8.0, 4.0, 3.0), "sill_r": _ellipse(-8.0, 4.0, 2.0)}
    assert clinical_measurements(LM, curves=curves)["nostril_symmetry"] == \
        pytest.approx(8.0 / 12.0, abs=1e-3)
    same = {"sill_l": _ellipse(8.0, 4.0, 3.0), "sill_r": _ellipse(-8.0, 3.0, 4.0)}
    assert clinical_measurements(LM, curves=same)["nostril_symmetry"] == \
        pytest.approx(1.0, abs=1e-3)
    assert "nostril_symmetry" not in clinical_measurements(LM, curves={"sill_l": curves["sill_l"]})
