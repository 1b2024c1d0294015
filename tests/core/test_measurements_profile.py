"""Profile and tip measurements on a synthetic midline profile with known answers.

The profile is a polyline in the plane x = 0 (SPEC frame, mm), made a triangle strip
+-4 mm across the midline, so the mesh's midline section is the polyline itself.
"""

from __future__ import annotations

import numpy as np
import pytest

from naseview.measurements import clinical_measurements

N = np.array([0.0, -15.0, -3.0])
PRN = np.array([0.0, -45.0, 25.0])
C = np.array([0.0, -50.0, 20.0])
SN = np.array([0.0, -55.0, 8.0])
U = (PRN - N) / np.linalg.norm(PRN - N)
A = np.array([0.0, U[2], -U[1]])                     # anterior normal of the n-prn line


def _dense(*pts: np.ndarray, step: float = 0.25) -> np.ndarray:
    """Polyline through ``pts`` (3,) with points every ``step`` mm (corners kept)."""
    out = [pts[0][None]]
    for p, q in zip(pts[:-1], pts[1:], strict=True):
        k = max(1, int(np.ceil(np.linalg.norm(q - p) / step)))
        out.append(p + np.linspace(0, 1, k + 1)[1:, None] * (q - p))
    return np.concatenate(out)


def _strip(profile: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Triangle strip (V, F) of ``profile`` (K, 3) extruded +-4 mm along x."""
    k = len(profile)
    V = np.concatenate([profile + [4.0, 0, 0], profile - [4.0, 0, 0]])
    F = np.array([[i, i + 1, k + i] for i in range(k - 1)]
                 + [[i + 1, k + i + 1, k + i] for i in range(k - 1)])
    return V, F


def _landmarks(**moved: np.ndarray) -> dict[str, np.ndarray]:
    lm = {"g": np.zeros(3), "n": N, "prn": PRN, "c": C, "sn": SN,
          "ac_l": np.array([15.0, -50, 1]), "ac_r": np.array([-15.0, -50, 1]),
          "mf_l": np.array([9.0, -17, -8]), "mf_r": np.array([-9.0, -17, -8])}
    lm.update(moved)
    return lm


def _dorsum(height: np.ndarray) -> np.ndarray:
    """Dorsum n->prn with ``height`` (41,) mm in front of the n-prn line."""
    s = np.linspace(0, 1, len(height))[:, None]
    return N + s * (PRN - N) + height[:, None] * A


LIP_DIR = np.array([0.0, -np.cos(np.radians(10)), np.sin(np.radians(10))])


def _face(dorsum: np.ndarray, lower: np.ndarray | None = None) -> np.ndarray:
    """Forehead g->n, ``dorsum`` n->prn, the lower nose prn-c-sn (or ``lower``), and 12 mm
    of upper lip below sn, tilted 10 deg forwards from the vertical."""
    low = _dense(PRN, C, SN) if lower is None else lower
    lip = _dense(low[-1], low[-1] + 12.0 * LIP_DIR)
    return np.concatenate([_dense(np.array([0.0, 10, -1]), np.zeros(3), N)[:-1], dorsum,
                           low[1:], lip[1:]])


HUMP = 3.0 * np.sin(np.pi * np.linspace(0, 1, 161)) ** 2


def test_hump_responds_one_to_one_when_the_dorsum_is_lowered() -> None:
    V, F = _strip(_face(_dorsum(HUMP)))
    assert clinical_measurements(_landmarks(), V=V, F=F)["dorsal_hump_depth"] == \
        pytest.approx(3.0, abs=0.01)
    # lower the dorsum by a 2 mm bump peaking at the hump apex (perpendicular to n-prn)
    V2, F2 = _strip(_face(_dorsum(HUMP - 2.0 / 3.0 * HUMP)))
    # the mesh is measured, not a lagging mid-curve passed along with it
    m = clinical_measurements(_landmarks(), curves={"mid": _face(_dorsum(HUMP))}, V=V2, F=F2)
    assert m["dorsal_hump_depth"] == pytest.approx(1.0, abs=0.05)
    saddle, Fs = _strip(_face(_dorsum(-HUMP)))
    assert clinical_measurements(_landmarks(), V=saddle, F=Fs)["dorsal_hump_depth"] == 0.0


def test_nasofrontal_angle_uses_the_dorsal_tangent_from_n() -> None:
    # a convex kink K 2 mm in front of n-prn, 40 % down: the tangent from n is n->K
    K = N + 0.4 * (PRN - N) + 2.0 * A
    V, F = _strip(_face(_dense(N, K, PRN)))
    m = clinical_measurements(_landmarks(), V=V, F=F)
    g, n = np.array([0.0, 0.0]), np.array([N[2], N[1]])
    ray_g, ray_k = g - n, np.array([K[2], K[1]]) - n
    want = np.degrees(np.arccos(ray_g @ ray_k / np.linalg.norm(ray_g) / np.linalg.norm(ray_k)))
    assert m["nasofrontal_angle"] == pytest.approx(want, abs=0.05)
    straight = np.degrees(np.arccos(-(N @ (PRN - N)) / np.linalg.norm(N) /
                                    np.linalg.norm(PRN - N)))
    assert want < straight - 3.0                   # the hump closes the angle
    Vs, Fs = _strip(_face(_dense(N, PRN)))
    assert clinical_measurements(_landmarks(), V=Vs, F=Fs)["nasofrontal_angle"] == \
        pytest.approx(straight, abs=0.05)


def test_nasolabial_angle_and_tip_rotation_of_known_lines() -> None:
    V, F = _strip(_face(_dense(N, PRN)))
    m = clinical_measurements(_landmarks(), V=V, F=F)
    col = (C - SN) / np.linalg.norm(C - SN)          # columella, directed to c
    want = np.degrees(np.arccos(col @ LIP_DIR))
    assert m["nasolabial_angle"] == pytest.approx(want, abs=0.3)
    # columellar-facial angle: 90 + the columella's elevation above the horizontal
    elev = np.degrees(np.arctan2(C[1] - SN[1], C[2] - SN[2]))
    assert m["tip_rotation"] == pytest.approx(90.0 + elev, abs=0.1)
    # without a mesh there is no lip below sn: no nasolabial angle, rotation from c-sn
    m2 = clinical_measurements(_landmarks())
    assert "nasolabial_angle" not in m2
    assert m2["tip_rotation"] == pytest.approx(90.0 + elev, abs=1e-6)


def _rotate_x(P: np.ndarray, centre: np.ndarray, deg: float) -> np.ndarray:
    """``P`` (K, 3) rotated by ``deg`` about the x axis through ``centre``; + turns +z
    (anterior) towards +y (up)."""
    t = np.radians(deg)
    R = np.array([[1, 0, 0], [0, np.cos(t), np.sin(t)], [0, -np.sin(t), np.cos(t)]])
    return (np.asarray(P) - centre) @ R.T + centre


def test_tip_rotated_up_by_5_degrees_reads_plus_5() -> None:
    base = np.array([0.0, -50.0, 1.0])                # the alar base (mean of ac)
    before = clinical_measurements(_landmarks(), V=_strip(_face(_dense(N, PRN)))[0],
                                   F=_strip(_face(_dense(N, PRN)))[1])
    low = _rotate_x(_dense(PRN, C, SN), base, 5.0)
    prn, c, sn = _rotate_x(np.array([PRN, C, SN]), base, 5.0)
    V, F = _strip(_face(_dense(N, prn), lower=low))
    after = clinical_measurements(_landmarks(prn=prn, c=c, sn=sn), V=V, F=F)
    assert after["tip_rotation"] - before["tip_rotation"] == pytest.approx(5.0, abs=0.5)


def test_tip_projection_goode_and_crumley() -> None:
    m = clinical_measurements(_landmarks())
    L = np.linalg.norm(PRN - N)
    assert m["tip_projection"] == pytest.approx(24.0)   # prn.z - ac.z
    assert m["goode_ratio"] == pytest.approx(24.0 / L)
    # Crumley: triangle n, ac (0, -50, 1), prn in the lateral view (z, y)
    n, ac, prn = np.array([-3.0, -15]), np.array([1.0, -50]), np.array([25.0, -45])
    h = (ac - n) / np.linalg.norm(ac - n)
    q = prn - n
    assert m["crumley_projection"] == pytest.approx(abs(q[0] * h[1] - q[1] * h[0]))
    assert m["crumley_ratio"] == pytest.approx(m["crumley_projection"] / L)
    assert m["crumley_height_ratio"] == pytest.approx(q @ h / L)
    # a 3:4:5 nose reads 0.6 and 0.8: n at the origin, ac 40 mm below, prn 30 mm in front
    lm = {"n": np.zeros(3), "ac_l": np.array([10.0, -40, 0]), "ac_r": np.array([-10.0, -40, 0]),
          "prn": np.array([0.0, -40, 30])}
    m345 = clinical_measurements(lm)
    assert m345["crumley_ratio"] == pytest.approx(0.6)
    assert m345["crumley_height_ratio"] == pytest.approx(0.8)
    assert m345["goode_ratio"] == pytest.approx(0.6)


def test_radix_height_and_level() -> None:
    m = clinical_measurements(_landmarks())
    assert m["radix_height"] == pytest.approx(5.0)      # n.z - mf.z = -3 - (-8)
    assert m["radix_level"] == pytest.approx(2.0)       # n.y - mf.y = -15 - (-17)


def test_columellar_show_from_the_nostril_outlines() -> None:
    # columella line sn (z 8, y -55) -> c (z 20, y -50); each nostril outline's lateral
    # part (the alar rim) rises 3 mm above it (left) / 2 mm (right) over z 10..18, its
    # medial part (beside the columella) stays at the columella's height
    z = np.linspace(10, 18, 9)
    line = -55.0 + (z - 8.0) * 5.0 / 12.0

    def sill(x: float, rise: float) -> np.ndarray:
        rim = np.stack([np.full_like(z, 1.3 * x), line + rise, z], axis=1)
        medial = np.stack([np.full_like(z, 0.7 * x), line, z], axis=1)[::-1]
        return np.concatenate([rim, medial])

    m = clinical_measurements(_landmarks(), curves={"sill_l": sill(6.0, 3.0),
                                                    "sill_r": sill(-6.0, 2.0)})
    assert m["columellar_show"] == pytest.approx(2.5)


def test_columellar_show_is_read_at_mid_columella() -> None:
    # the alar rim stands 2 mm above the columella over its front half but rises to 6 mm
    # at sn (the alar base above the columella's foot): the show is the 2 mm (mid), not
    # the 6 mm at the foot (issue 27: a columella set-back did not change the figure)
    z = np.linspace(8.5, 18, 20)                      # sn at z 8, c at z 20
    line = -55.0 + (z - 8.0) * 5.0 / 12.0
    rise = 2.0 + np.clip(14.0 - z, 0.0, None)

    def sill(x: float) -> np.ndarray:
        rim = np.stack([np.full_like(z, 1.3 * x), line + rise, z], axis=1)
        medial = np.stack([np.full_like(z, 0.7 * x), line, z], axis=1)[::-1]
        return np.concatenate([rim, medial])

    m = clinical_measurements(_landmarks(), curves={"sill_l": sill(6.0),
                                                    "sill_r": sill(-6.0)})
    assert m["columellar_show"] == pytest.approx(2.0, abs=0.05)


def test_measurements_do_not_depend_on_the_head_pose() -> None:
    """A yaw of the whole face (landmarks and mesh) changes nothing: the facial
    midline plane and the projections turn with the face."""
    V, F = _strip(_face(_dorsum(HUMP)))
    lm = _landmarks(al_l=np.array([17.0, -48, 5]), al_r=np.array([-17.0, -48, 5]))
    m0 = clinical_measurements(lm, V=V, F=F)
    t = np.radians(20.0)
    Ry = np.array([[np.cos(t), 0, np.sin(t)], [0, 1, 0], [-np.sin(t), 0, np.cos(t)]])
    m1 = clinical_measurements({k: Ry @ p for k, p in lm.items()}, V=V @ Ry.T, F=F)
    assert set(m1) == set(m0)
    for k in m0:
        assert m1[k] == pytest.approx(m0[k], abs=1e-6), k
