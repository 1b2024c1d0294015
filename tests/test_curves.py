"""Stage 2: boundary curves and ad-landmarks (paper section 3.3)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest

from naseview.camera import look_at
from naseview.landmarks import CURVE_NAMES, LANDMARK_IDS
from naseview.stage2_curves import CurveParams, StepCache
from naseview.stage2_curves.edges import edge_cost, edge_map, least_cost_path, smooth_polyline
from naseview.stage2_curves.fallback import catmull_rom_segments
from naseview.stage2_curves.lift import closest_points_between_lines, lift_to_lines, lift_to_plane
from naseview.stage2_curves.mask import estimate_background, foreground_mask, profile_contour
from naseview.stage2_curves.metrics import boundary_errors, hausdorff_polylines, point_to_polyline
from naseview.stage2_curves.nostrils import nostril_contour, sill_plane
from naseview.stage2_curves.side import arc_through, circle_through_points, side_tmp_point
from naseview.stage2_curves.sublandmarks import ad_landmarks, sample_curve

# ----------------------------------------------------------------- lifting (eq. 4-10)


def test_lift_returns_exact_point_when_lines_intersect() -> None:
    rng = np.random.default_rng(0)
    cam = look_at([300.0, 20, 10], [0, 0, 0], [0, 1, 0], 2000.0, 1024, 1024)
    for _ in range(20):
        A, B = rng.normal(0, 20, 3), rng.normal(0, 20, 3)
        X = A + rng.uniform(0.1, 0.9) * (B - A)          # a point of line AB
        uv = cam.project(X[None])
        for w in (0.0, 0.5, 1.0):
            np.testing.assert_allclose(lift_to_lines(uv, cam, A, B, w)[0], X, atol=1e-6)


def test_closest_points_of_skew_and_parallel_lines() -> None:
    P1, P2 = closest_points_between_lines([0.0, 0, 0], [[1.0, 0, 0]], [[0.0, 2, 5]],
                                          [[0.0, 0, 1]])
    np.testing.assert_allclose(P1[0], [0, 0, 0], atol=1e-12)
    np.testing.assert_allclose(P2[0], [0, 2, 0], atol=1e-12)
    P1, P2 = closest_points_between_lines([0.0, 0, 0], [[1.0, 0, 0]], [[3.0, 1, 0]],
                                          [[2.0, 0, 0]])
    assert np.isclose(np.linalg.norm(P1[0] - P2[0]), 1.0)
    # eq. 10 midpoint lies halfway between the two lines
    cam = look_at([0.0, 0, 100], [0, 0, 0], [0, 1, 0], 500.0, 64, 64)
    X = lift_to_lines(cam.project(np.zeros((1, 3))), cam, [-10.0, 1, 0], [10.0, 1, 0])
    np.testing.assert_allclose(X[0], [0.0, 0.5, 0.0], atol=1e-9)


def test_lift_to_plane_hits_the_plane_on_the_line_of_sight() -> None:
    cam = look_at([0.0, -200, 50], [0, 0, 0], [0, 0, 1], 900.0, 256, 256)
    X = np.array([[3.0, 1.0, -2.0], [-4.0, 2.5, 1.0]])
    p, n = sill_plane([3.0, 1.0, -2.0], [5.0, 2.0, 4.0], [0.0, 1.0, 6.0])
    X[1] -= ((X[1] - p) @ n) * n                           # move the 2nd point into the plane
    np.testing.assert_allclose(lift_to_plane(cam.project(X), cam, p, n), X, atol=1e-8)
    assert abs(n[2]) < 1e-12 and n[1] > 0                   # parallel to Oxy, oriented +y
    assert abs(n @ np.array([5.0 - 0.0, 2.0 - 1.0, 4.0 - 6.0])) < 1e-12  # perpendicular to md-c

# ----------------------------------------------------------------- side-curve (eq. 15-17)


def test_circle_through_three_points() -> None:
    rng = np.random.default_rng(1)
    for _ in range(10):
        c0, r0 = rng.normal(0, 50, 2), rng.uniform(5, 80)
        a = rng.uniform(0, 2 * np.pi, 3)
        P = c0 + r0 * np.column_stack([np.cos(a), np.sin(a)])
        c, r = circle_through_points(*P)
        np.testing.assert_allclose(c, c0, atol=1e-7)
        assert np.isclose(r, r0)
    assert circle_through_points([0, 0], [1, 1], [2, 2])[1] == np.inf


def test_side_arc_passes_through_int_tmp_mf() -> None:
    i, m = np.array([400.0, 600.0]), np.array([430.0, 380.0])
    tmp = side_tmp_point(i, m, 1.0, 3.0)
    np.testing.assert_allclose(tmp, [415.0, 435.0])         # w1 = w2, h2 = 3 h1 (eq. 15)
    # the arc is steep next to int and flat next to mf: it bows towards the midline
    chord_x_at_tmp = 400.0 + 30.0 * (600.0 - 435.0) / 220.0
    assert tmp[0] < chord_x_at_tmp
    bulged = side_tmp_point(i, m, 1.0, 3.0, bulge=0.1, toward=[300.0, 500.0])
    assert np.isclose(np.linalg.norm(bulged - tmp), 0.1 * np.hypot(30, 220))
    assert bulged[0] < tmp[0]
    arc = arc_through(i, tmp, m, 200)
    np.testing.assert_allclose(arc[0], i, atol=1e-9)
    np.testing.assert_allclose(arc[-1], m, atol=1e-9)
    assert point_to_polyline(tmp[None], arc)[0] < 0.05
    assert np.ptp(arc[:, 1]) <= 221                         # no detour round the circle

# ----------------------------------------------------------------- edges and paths (eq. 11-12)


def test_least_cost_path_follows_a_drawn_edge() -> None:
    img = np.full((300, 300), 120, np.uint8)
    cv2.ellipse(img, (150, 150), (100, 60), 0, 0, 360, 170, -1)   # faint skin-like edge
    rng = np.random.default_rng(2)
    img = np.clip(img + rng.normal(0, 3, img.shape), 0, 255).astype(np.uint8)
    em = edge_map(img, (0, 0, 300, 300), blur_sigma=1.0)
    start, end = np.array([50.0, 150.0]), np.array([150.0, 90.0])  # two points of the edge
    path = least_cost_path(edge_cost(em.strength), start, end, corridor=40)
    assert path is not None
    np.testing.assert_allclose(path[0], start)
    np.testing.assert_allclose(path[-1], end)
    r = np.hypot((path[:, 0] - 150) / 100, (path[:, 1] - 150) / 60)
    d_px = np.abs(r - 1) * 60                               # radial offset, px (upper bound)
    assert np.median(d_px) < 1.5 and d_px.max() < 4
    # the straight chord would be far from the ellipse
    chord = start + np.linspace(0, 1, 50)[:, None] * (end - start)
    assert np.abs(np.hypot((chord[:, 0] - 150) / 100, (chord[:, 1] - 150) / 60) - 1).max() > 0.2


def test_smoothing_keeps_ends_and_straight_lines() -> None:
    P = np.column_stack([np.arange(30.0), 2.0 * np.arange(30.0)])
    S = smooth_polyline(P, 2.0)
    np.testing.assert_allclose(S[[0, -1]], P[[0, -1]])
    assert point_to_polyline(S, P).max() < 1e-9

# ----------------------------------------------------------------- nostrils (eq. 13-14)


def test_nostril_contour_found_on_a_drawn_dark_blob() -> None:
    img = np.full((200, 200, 3), (120, 150, 190), np.uint8)
    cv2.ellipse(img, (90, 110), (30, 16), 20, 0, 360, (30, 30, 40), -1)
    rng = np.random.default_rng(3)
    speck = rng.uniform(size=img.shape[:2]) < 0.03           # bright specks inside: closing
    img[speck] = 140
    ang = np.deg2rad(20)
    seed = np.array([90 + 33 * np.cos(ang), 110 + 33 * np.sin(ang)])   # just outside the rim
    loop = nostril_contour(img, seed, threshold=80, closing_px=5, search_px=12)
    assert loop is not None and len(loop) > 50
    # distance of the traced loop to the drawn ellipse
    t = np.linspace(0, 2 * np.pi, 720)
    E = np.column_stack([30 * np.cos(t), 16 * np.sin(t)]) @ np.array(
        [[np.cos(ang), np.sin(ang)], [-np.sin(ang), np.cos(ang)]]) + [90, 110]
    assert point_to_polyline(loop, E, closed=True).max() < 1.6
    assert np.linalg.norm(loop[0] - seed) < 5                # loop starts next to al''
    assert nostril_contour(img, [190.0, 10.0], 80, 5, 12) is None     # nothing dark there

# ----------------------------------------------------------------- background (eq. 2-3)


def _profile_photo(border_noise: bool = False) -> tuple[np.ndarray, np.ndarray]:
    img = np.full((240, 240, 3), (235, 180, 60), np.uint8)   # uniform blue backdrop (BGR)
    head = np.array([[60, 20], [150, 20], [150, 90], [120, 110], [135, 150], [110, 160],
                     [150, 200], [150, 240], [60, 240]], np.int32)
    cv2.fillPoly(img, [head], (120, 150, 200))
    if border_noise:
        rng = np.random.default_rng(4)
        img[:40] = rng.integers(0, 255, (40, 240, 3))
        img[:, -40:] = rng.integers(0, 255, (240, 40, 3))
    return img, head


def test_background_estimated_from_border_and_profile_found() -> None:
    img, head = _profile_photo()
    bg = estimate_background(img, border_px=8)
    assert bg.uniform and bg.inlier_fraction > 0.85   # the neck touches the border
    mask = foreground_mask(img, bg)
    truth = np.zeros(mask.shape, np.uint8)
    cv2.fillPoly(truth, [head], 1)
    assert (mask != truth.astype(bool)).mean() < 0.01
    # profile from (150, 40) to (150, 190), face pointing to the image right
    prof = profile_contour(mask, [150.0, 40.0], [150.0, 190.0], anterior=+1)
    assert prof is not None
    assert point_to_polyline([[120.0, 110.0], [135.0, 150.0], [110.0, 160.0]], prof).max() < 2
    assert prof[:, 0].max() <= 151 and prof[:, 1].min() >= 35


def test_non_uniform_border_is_detected() -> None:
    img, _ = _profile_photo(border_noise=True)
    assert not estimate_background(img, border_px=8).uniform

# ----------------------------------------------------------------- sub-landmarks


def test_sub_landmarks_split_by_segment_length() -> None:
    P = np.column_stack([np.linspace(0, 30, 61), np.zeros(61), np.zeros(61)])
    X, tags = sample_curve(P, [("a", 0), ("b", 20), ("c", 60)], 6, "mid")
    assert [t["between"] for t in tags].count(["a", "b"]) == 2      # 10 mm of 30 mm
    np.testing.assert_allclose([t["t"] for t in tags], X[:, 0] / 30.0)
    L = np.vstack([[0.0, 0, 0], [5, 0, 0], [5, 5, 0], [0, 5, 0]])
    X, tags = sample_curve(L, [("alpp_l", 2)], 3, "sill_l", closed=True)
    assert len(X) == 3 and tags[0]["between"] == ["alpp_l", "alpp_l"]
    assert point_to_polyline(X, L, closed=True).max() < 1e-12


def test_76_ad_landmarks_with_tags() -> None:
    rng = np.random.default_rng(5)
    lms = {k: rng.normal(0, 20, 3) for k in LANDMARK_IDS}
    curves, anchors = {}, {}
    for name in CURVE_NAMES:
        P = np.cumsum(rng.normal(0, 1, (40, 3)), axis=0)
        curves[name] = P
        anchors[name] = [("alpp_" + name[-1], 0)] if name.startswith("sill") else \
            [("x", 0), ("y", 17), ("z", 39)]
    X, tags = ad_landmarks(lms, curves, anchors, CurveParams().sub_landmarks)
    assert X.shape == (76, 3) and len(tags) == 76
    assert [t["id"] for t in tags[:21]] == list(LANDMARK_IDS)
    assert all({"id", "curve", "t", "between", "s"} <= set(t) for t in tags)
    assert len({t["id"] for t in tags}) == 76
    assert all(0 < t["t"] < 1 for t in tags[21:])

# ----------------------------------------------------------------- metrics, fallback, params


def test_boundary_errors_in_mm() -> None:
    cam = look_at([0.0, 0, 200], [0, 0, 0], [0, 1, 0], 1000.0, 512, 512)
    P3 = np.column_stack([np.linspace(-10, 10, 21), np.zeros(21), np.zeros(21)])
    T = cam.project(P3 + [0, 1.0, 0])                       # truth 1 mm above, 5 px/mm
    r = boundary_errors({"c": P3}, {"front": cam}, {"c": {"front": T}}, px_per_mm=5.0)
    assert np.isclose(r["families"]["c"]["mae_mm"], 1.0)
    assert np.isclose(r["families"]["c"]["hausdorff_mm"], 1.0)
    assert hausdorff_polylines(T, T[:5]) > 10


def test_catmull_rom_through_landmarks() -> None:
    P = np.array([[0.0, 0, 0], [10, 5, 0], [20, 0, 3], [30, 2, 1]])
    segs = catmull_rom_segments(P, 20)
    assert len(segs) == 3
    for i, s in enumerate(segs):
        np.testing.assert_allclose(s[[0, -1]], P[[i, i + 1]])


def test_params_validate_and_default_to_55() -> None:
    assert CurveParams().total_sub_landmarks() == 55
    with pytest.raises(ValueError, match="closing_px"):
        CurveParams(closing_px=-1).validated()
    with pytest.raises(ValueError, match="sub_landmarks"):
        CurveParams(sub_landmarks={"nose": 3}).validated()


def test_step_cache_reuses_by_key() -> None:
    c = StepCache(max_entries=2)
    calls = []
    for k in (1, 2, 1, 3, 1):
        c.get("s", str(k), lambda k=k: calls.append(k) or k)
    assert calls == [1, 2, 3] and c.hits["s"] == 2

# ----------------------------------------------------------------- on a synthetic ICT case

SynthCase = tuple[Path, Any, Any, dict[str, np.ndarray]]
"""(case directory, Case, stage-1 SfmResult, photos by view)."""


@pytest.fixture(scope="module")
def synth_case(tmp_path_factory: pytest.TempPathFactory, ict_dir: Path) -> SynthCase:
    """One rendered ICT case (512 px), its stage-1 result and its photos."""
    from naseview.case import read_case
    from naseview.facemodel import load_face_model
    from naseview.stage1_landmarks.solve import bundle_adjust
    from naseview.testbed.synth import synthesize_case

    d = synthesize_case(tmp_path_factory.mktemp("s2") / "case", load_face_model("ict"),
                        seed=3, size=512).parent
    case = read_case(d)
    return d, case, bundle_adjust(case), {v: case.load_image(v) for v in case.views}


def _errors(d: Path, res: Any, sfm: Any) -> dict[str, Any]:
    from naseview.fileio import read_json
    from naseview.reconstruction import read_reconstruction
    from naseview.stage2_curves.metrics import boundary_errors, px_per_mm_from_truth

    truth = read_reconstruction(d / "truth.json")
    ppm = px_per_mm_from_truth(truth.landmarks, truth.cameras["front"])
    return boundary_errors(res.curves, sfm.cameras, read_json(d / "truth_boundaries.json"), ppm)


def test_synthetic_case_curves_close_to_truth(synth_case: SynthCase) -> None:
    from naseview.stage2_curves import extract_curves

    d, case, sfm, images = synth_case
    res = extract_curves(case, images, sfm)
    assert list(res.curves) == list(CURVE_NAMES)
    assert all(f != "missing" for f in res.flags.values())
    assert res.flags["side_l"] == res.flags["side_r"] == "circle"
    err = _errors(d, res, sfm)
    fam = {k: v["mae_mm"] for k, v in err["families"].items()}
    # measured on this case (512 px): mid 0.1, bottom 0.4, ala 0.35, c 0.3, sill 0.3, side 1.2
    bounds = {"mid": 0.5, "bottom": 1.0, "ala": 1.0, "c": 1.0, "sill": 0.8, "side": 2.0}
    assert all(fam[k] < b for k, b in bounds.items()), fam
    assert err["mean_mae_mm"] < 1.0
    # 2D evidence for display, in the photo of each curve
    assert set(res.curves_2d["mid"]) == {"left", "right"}
    assert set(res.curves_2d["bottom"]) == {"bottom"} and set(res.curves_2d["c"]) == {"front"}
    assert res.evidence["left"]["mask"].dtype == bool
    assert res.evidence["front"]["edges"].strength.max() <= 1.0
    # sills are closed loops starting at al''
    for s in "lr":
        loop = res.curves[f"sill_{s}"]
        assert len(loop) > 10
        assert np.linalg.norm(loop[0] - sfm.landmarks[f"alpp_{s}"]) < 1.5


def test_ad_landmarks_of_a_case(synth_case: SynthCase) -> None:
    from naseview.stage2_curves import extract_curves

    _, case, sfm, images = synth_case
    res = extract_curves(case, images, sfm)
    assert res.ad_landmarks.shape == (76, 3) and len(res.ad_landmark_tags) == 76
    for X, tag in zip(res.ad_landmarks[21:], res.ad_landmark_tags[21:], strict=True):
        assert point_to_polyline(X[None], res.curves[tag["curve"]],
                                 tag["curve"].startswith("sill"))[0] < 1e-6
    np.testing.assert_allclose(res.ad_landmarks[:21],
                               [sfm.landmarks[k] for k in LANDMARK_IDS])


def test_parameter_change_reuses_cached_steps(synth_case: SynthCase) -> None:
    from naseview.stage2_curves import extract_curves

    _, case, sfm, images = synth_case
    cache = StepCache()
    first = extract_curves(case, images, sfm, CurveParams(), cache)
    assert cache.misses["mask"] == 2 and cache.misses["edges"] == 2
    cache.reset_stats()
    second = extract_curves(case, images, sfm, CurveParams(closing_px=9), cache)
    assert set(cache.misses) == {"nostril"}               # only the nostrils re-ran
    assert cache.hits["mask"] == 2 and cache.hits["path"] >= 10
    for name in ("mid", "bottom", "ala_l", "c", "side_r"):
        np.testing.assert_array_equal(first.curves[name], second.curves[name])
    cache.reset_stats()
    extract_curves(case, images, sfm, CurveParams(side_bulge=0.0), cache)
    assert not cache.misses                                # side-curves are not cached


def test_non_uniform_border_warns_and_falls_back(synth_case: SynthCase) -> None:
    from naseview.stage2_curves import extract_curves

    _, case, sfm, images = synth_case
    rng = np.random.default_rng(0)
    bad = dict(images)
    for v in ("left", "right"):
        img = images[v].copy()
        noise = rng.integers(0, 256, img.shape, dtype=np.uint8)
        edge = np.ones(img.shape[:2], bool)
        edge[40:-40, 40:-40] = False
        img[edge] = noise[edge]
        bad[v] = img
    res = extract_curves(case, {**images, "left": bad["left"]}, sfm)
    assert any(w.startswith("mid: photo 'left'") and "uniform background" in w
               for w in res.warnings)
    assert res.flags["mid"] == "image"                     # the right photo still serves
    res = extract_curves(case, bad, sfm)
    assert res.flags["mid"] == "fallback"
    assert sum(w.startswith("mid: photo ") for w in res.warnings) == 2
    assert len(res.curves["mid"]) > 10 and res.ad_landmarks.shape == (76, 3)


def test_missing_edges_and_nostrils_warn_and_fall_back(synth_case: SynthCase) -> None:
    from naseview.stage2_curves import extract_curves
    from naseview.stage2_curves.extract import anchors_2d

    _, case, sfm, images = synth_case
    front = images["front"].copy()
    an = anchors_2d(case, "front", sfm.landmarks, sfm.cameras["front"])
    pts = np.array([an[k] for k in ("md_l", "md_r", "c", "al_l", "al_r", "prn")])
    x0, y0 = (pts.min(0) - 30).astype(int)
    x1, y1 = (pts.max(0) + 30).astype(int)
    front[y0:y1, x0:x1] = front[y0:y1, x0:x1].reshape(-1, 3).mean(0)   # a flat patch
    bottom = images["bottom"].copy()
    v = bottom.max(axis=2)
    dark = cv2.dilate((v < 0.8 * np.median(v)).astype(np.uint8), np.ones((7, 7))) > 0
    bottom[dark] = np.median(bottom[~dark], axis=0)                     # nostrils gone
    res = extract_curves(case, {**images, "front": front, "bottom": bottom}, sfm)
    assert res.flags["c"] == "fallback"
    assert any(w.startswith("c: photo 'front' (front.") and "no edge found" in w
               for w in res.warnings)
    for s in "lr":
        assert res.flags[f"sill_{s}"] == "fallback"
        assert any(w.startswith(f"sill_{s}: photo 'bottom'") and "not visible" in w
                   for w in res.warnings)
        assert len(res.curves[f"sill_{s}"]) > 8
    # the fallback C-curve still runs md_r -> c -> md_l through the stage-1 landmarks
    C = res.curves["c"]
    for k in ("md_r", "c", "md_l"):
        assert point_to_polyline(sfm.landmarks[k][None], C)[0] < 0.6


def test_pipeline_fills_curves_and_ad_landmarks(synth_case: SynthCase, tmp_path: Path) -> None:
    import json

    from naseview.pipeline import reconstruct, write_outputs

    _, case, _, _ = synth_case
    result = reconstruct(case, stages=(1, 2))
    rec = result.reconstruction
    assert set(rec.curves) == set(CURVE_NAMES) and rec.ad_landmarks.shape == (76, 3)
    assert "curves" in result.stage_seconds
    write_outputs(result, tmp_path)
    out = json.loads((tmp_path / "reconstruction.json").read_text())
    assert len(out["ad_landmarks"]) == 76 and len(out["ad_landmark_tags"]) == 76
    assert set(out["curves"]) == set(CURVE_NAMES)
