"""Surgical manoeuvres as displacement fields, on the ICT mean face and on the demo
reconstruction (the default face model, ICT in the tests): each moves its landmark by its
amount, stays in its region, never folds the mesh, and the fields add."""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest
from helpers import demo_output_dir, ict_baseline

from naseview.editing.baseline import Baseline, baseline_from_output_dir
from naseview.editing.manoeuvres import MANOEUVRES, ManoeuvrePlan, folded_triangles
from naseview.editing.manoeuvres.plan import HUMP_MARGIN_MM
from naseview.editing.manoeuvres.tip import tip_rotation_pivot
from naseview.geometry.region import grow_by_distance
from naseview.measurements import clinical_measurements

FACES = ("ict", "demo")


def _demo_baseline() -> Baseline:
    """The bundled demo case reconstructed (default face model: ICT in the tests)."""
    return baseline_from_output_dir(demo_output_dir())


@cache
def _face(name: str) -> tuple[Baseline, ManoeuvrePlan]:
    b = ict_baseline() if name == "ict" else _demo_baseline()
    return b, ManoeuvrePlan(b.V, b.F, b.nose_ids, b.landmarks, b.curves)


def _moved(b: Baseline, plan: ManoeuvrePlan, amounts: dict[str, float]
           ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    V = b.V + plan.displacement(amounts)
    off = plan.landmark_offsets(amounts)
    return V, {k: b.landmarks[k] + off[k] for k in b.landmarks}


def _amounts(name: str) -> list[float]:
    """low, mid and high of a manoeuvre's range (0 left out)."""
    m = MANOEUVRES[name]
    return [x for x in (m.low, 0.5 * (m.low + m.high), m.high) if x != 0.0]


def _edges(F: np.ndarray) -> np.ndarray:
    E = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    return np.unique(np.sort(E, axis=1), axis=0)


@pytest.mark.parametrize("face", FACES)
def test_every_manoeuvre_is_available_with_the_21_landmarks(face):
    _, plan = _face(face)
    assert plan.available == tuple(MANOEUVRES)


@pytest.mark.parametrize("face", FACES)
def test_hump_reduction_lowers_the_hump_measure_by_the_amount(face):
    b, plan = _face(face)
    h0 = clinical_measurements(b.landmarks, None, b.V, b.F)["dorsal_hump_depth"]
    assert h0 > 1.0                                    # both faces have a hump to take
    amount = 2.0 if h0 >= 2.0 else round(h0 - 0.5, 1)   # a reduction the hump allows
    V, lms = _moved(b, plan, {"hump_reduction": amount})
    h1 = clinical_measurements(lms, None, V, b.F)["dorsal_hump_depth"]
    assert h0 - h1 == pytest.approx(amount, abs=0.2)
    assert np.linalg.norm(lms["n"] - b.landmarks["n"]) < 1e-6       # the line n-prn stays
    assert np.linalg.norm(lms["prn"] - b.landmarks["prn"]) < 1e-6
    V, lms = _moved(b, plan, {"hump_reduction": h0 + 1.0})      # past straight
    assert clinical_measurements(lms, None, V, b.F)["dorsal_hump_depth"] < 0.2


@pytest.mark.parametrize("face", FACES)
def test_hump_reduction_moves_only_the_dorsum(face):
    b, plan = _face(face)
    D = np.linalg.norm(plan.displacement({"hump_reduction": 5.0}), axis=1)
    n, prn = b.landmarks["n"], b.landmarks["prn"]
    outside = (np.abs(b.V[:, 0]) > 9.0) | (b.V[:, 1] < prn[1]) | (b.V[:, 1] > n[1])
    assert D[outside].max() <= 0.2
    cap = min(5.0, plan.hump_depth + HUMP_MARGIN_MM)     # capped where the dorsum is straight
    assert D.max() == pytest.approx(cap, abs=0.05)      # the apex goes down by the amount


def _prn_rotation_deg(plan: ManoeuvrePlan, prn0: np.ndarray, prn1: np.ndarray) -> float:
    """Signed angle (deg) of prn about the tip-rotation axis (+ = cephalic)."""
    assert plan.frame is not None
    pivot, axis = tip_rotation_pivot(plan.frame)
    r0, r1 = prn0 - pivot, prn1 - pivot
    r0, r1 = r0 - (r0 @ axis) * axis, r1 - (r1 @ axis) * axis
    return float(np.degrees(np.arctan2(np.cross(r0, r1) @ axis, r0 @ r1)))


@pytest.mark.parametrize("face", FACES)
@pytest.mark.parametrize("name", ["radix_augmentation", "tip_projection", "tip_rotation",
                                  "tip_narrowing", "alar_base_narrowing"])
def test_each_manoeuvre_moves_its_landmark_by_the_amount(face, name):
    b, plan = _face(face)
    L = b.landmarks
    for amount in _amounts(name):
        _, lms = _moved(b, plan, {name: amount})
        d = {k: lms[k] - L[k] for k in L}
        if name == "radix_augmentation":
            assert np.linalg.norm(d["n"]) == pytest.approx(abs(amount), abs=0.05)
            assert d["n"][2] * amount > 0                       # out of the face (+z)
        elif name == "tip_projection":
            assert d["prn"][2] == pytest.approx(amount, abs=0.05)
            assert np.linalg.norm(d["prn"]) == pytest.approx(abs(amount), abs=0.05)
        elif name == "tip_rotation":
            got = _prn_rotation_deg(plan, L["prn"], lms["prn"])   # scaled by the gain
            assert got == pytest.approx(amount / plan.rotation_gain, abs=0.3)
            assert d["prn"][1] * amount > 0                     # + turns the tip up
        elif name == "tip_narrowing":
            w0 = np.linalg.norm(L["md_l"] - L["md_r"])
            w1 = np.linalg.norm(lms["md_l"] - lms["md_r"])
            assert w0 - w1 == pytest.approx(amount, abs=0.3)
        else:
            assert plan.frame is not None
            e = plan.frame.e
            for k in ("al_l", "ac_l"):
                assert -d[k] @ e == pytest.approx(amount, abs=0.1)
            for k in ("al_r", "ac_r"):
                assert d[k] @ e == pytest.approx(amount, abs=0.1)
            for s in ("l", "r"):                                 # the ala is not pinched
                before = np.linalg.norm(L[f"al_{s}"] - L[f"ac_{s}"])
                after = np.linalg.norm(lms[f"al_{s}"] - lms[f"ac_{s}"])
                assert abs(after - before) < 0.3


@pytest.mark.parametrize("face", FACES)
def test_columella_setback_raises_the_columella_and_keeps_tip_and_lip(face):
    b, plan = _face(face)
    c, sn = b.landmarks["c"], b.landmarks["sn"]
    D = plan.displacement({"columella_setback": 3.0})
    off = plan.landmark_offsets({"columella_setback": 3.0})
    assert np.linalg.norm(off["c"]) < 0.05 and np.linalg.norm(off["sn"]) < 0.05
    mid = int(np.argmin(np.linalg.norm(b.V - 0.5 * (c + sn), axis=1)))   # mid-columella
    assert np.linalg.norm(D[mid]) == pytest.approx(3.0, abs=0.5)
    assert D[mid][1] > 0 and D[mid][2] < 0                      # up and back, into the nose


@pytest.mark.parametrize("face", FACES)
def test_no_fold_overs_anywhere_in_the_ranges(face):
    b, plan = _face(face)
    plans = [{name: x} for name in MANOEUVRES for x in _amounts(name)]
    plans.append({name: m.high for name, m in MANOEUVRES.items()})
    plans.append({name: m.low for name, m in MANOEUVRES.items()})      # lows (negatives)
    plans.append({"radix_augmentation": -2.0, "tip_projection": -4.0, "tip_rotation": 15.0,
                  "hump_reduction": 5.0, "alar_base_narrowing": 4.0})
    for amounts in plans:
        V = b.V + plan.displacement(amounts)
        folded = folded_triangles(b.V, V, b.F)
        assert len(folded) == 0, (amounts, folded[:5])


@pytest.mark.parametrize("face", FACES)
def test_fields_stay_in_their_region_and_are_smooth(face):
    b, plan = _face(face)
    E = _edges(b.F)
    rest = np.linalg.norm(b.V[E[:, 0]] - b.V[E[:, 1]], axis=1)
    outside_nose = np.setdiff1d(np.arange(len(b.V)), b.nose_ids)
    outside_region = np.setdiff1d(np.arange(len(b.V)), plan.region_ids)
    assert plan.frame is not None
    band = grow_by_distance(b.V, b.F, b.nose_ids, 0.7 * plan.frame.width)
    assert np.isin(plan.region_ids, band).all()         # the fade bands hug the nose
    for name in MANOEUVRES:
        for x in _amounts(name):
            D = plan.displacement({name: x})
            assert np.abs(D[outside_region]).max() == 0.0
            if name in ("hump_reduction", "tip_projection", "tip_narrowing",
                        "columella_setback"):
                assert np.abs(D[outside_nose]).max() == 0.0
            dD = D[E[:, 0]] - D[E[:, 1]]
            ratio = np.linalg.norm(dD, axis=1) / rest
            assert ratio.max() < 1.2, (name, x, ratio.max())     # gradient bounded
            moved = np.linalg.norm(b.V[E[:, 0]] + dD - b.V[E[:, 1]], axis=1)
            assert (moved / rest).min() > 0.4, (name, x)          # no edge crushed


@pytest.mark.parametrize("face", FACES)
def test_fields_add_exactly_and_an_empty_plan_is_zero(face):
    b, plan = _face(face)
    assert np.array_equal(plan.displacement({}), np.zeros_like(b.V))
    assert all(not np.any(v) for v in plan.landmark_offsets({}).values())
    a = {"hump_reduction": 0.5, "tip_projection": 2.0, "alar_base_narrowing": 1.0}
    # the hump amounts together within the hump (beyond it the reduction is capped)
    c = {"hump_reduction": 0.7, "tip_narrowing": 1.5, "radix_augmentation": -1.0,
         "columella_setback": 2.5}
    both = {k: a.get(k, 0.0) + c.get(k, 0.0) for k in {*a, *c}}
    np.testing.assert_allclose(plan.displacement(both),
                               plan.displacement(a) + plan.displacement(c), atol=1e-12)
    np.testing.assert_allclose(plan.displacement({"tip_projection": 3.0}),
                               3.0 * plan.displacement({"tip_projection": 1.0}), atol=1e-12)
    mix = {"tip_rotation": 8.0, **a}
    assert np.array_equal(plan.displacement(mix),
                          plan.displacement(dict(reversed(list(mix.items())))))
    rot = plan.displacement({"tip_rotation": 8.0})
    np.testing.assert_allclose(plan.displacement(mix), plan.displacement(a) + rot,
                               atol=1e-12)


@pytest.mark.parametrize("face", FACES)
def test_landmarks_stay_on_the_displaced_surface(face):
    b, plan = _face(face)
    tri = b.F[np.isin(b.F, b.nose_ids).all(axis=1)]
    probes = b.V[tri[::97]].mean(axis=1)                       # triangle centroids
    lms = {**b.landmarks, **{f"probe{i}": p for i, p in enumerate(probes)}}
    probe_plan = ManoeuvrePlan(b.V, b.F, b.nose_ids, lms, b.curves)
    amounts = {name: m.high for name, m in MANOEUVRES.items()}
    V = b.V + probe_plan.displacement(amounts)
    off = probe_plan.landmark_offsets(amounts)
    moved = np.array([probes[i] + off[f"probe{i}"] for i in range(len(probes))])
    assert np.linalg.norm(moved - V[tri[::97]].mean(axis=1), axis=1).max() < 0.05
    for k, p in b.landmarks.items():                          # the 21 sit on vertices
        i = int(np.argmin(np.linalg.norm(b.V - p, axis=1)))
        assert np.linalg.norm(p + off[k] - V[i]) < 0.05 + np.linalg.norm(b.V[i] - p)


def test_a_plan_without_the_landmarks_a_manoeuvre_needs_skips_it():
    b, _ = _face("ict")
    lms = {k: v for k, v in b.landmarks.items() if k not in ("md_l", "c")}
    plan = ManoeuvrePlan(b.V, b.F, b.nose_ids, lms)
    assert "tip_narrowing" not in plan.available
    assert "columella_setback" not in plan.available
    assert "tip_projection" in plan.available
    assert not plan.displacement({"tip_narrowing": 2.0}).any()
    bare = ManoeuvrePlan(b.V, b.F, b.nose_ids, {"g": b.landmarks["g"]})
    assert bare.available == ()
    assert not bare.displacement({"hump_reduction": 2.0}).any()


def test_folded_triangles_finds_a_flipped_and_a_crushed_triangle():
    V0 = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]])
    F = np.array([[0, 1, 2], [1, 3, 2]])
    assert folded_triangles(V0, V0, F).tolist() == []
    flipped = V0.copy()
    flipped[3] = [-0.5, -0.5, 0.0]                 # vertex 3 dragged across the diagonal
    assert folded_triangles(V0, flipped, F).tolist() == [1]
    crushed = V0.copy()
    crushed[3] = [0.52, 0.52, 0.0]                 # onto the diagonal: area ~4 %
    assert folded_triangles(V0, crushed, F).tolist() == [1]
    assert folded_triangles(V0, crushed, F, np.array([0])).tolist() == []
