"""One-line errors of stage 1 (paper §3.2): clicks eq. 1 cannot use, and fits that failed.

Every error is a :class:`~naseview.errors.NaseviewError` that names ``case.json``, the key
(``views.<photo>.landmarks``, ``scale_mm``, ...) and what to do. The input checks run once,
before any solve; the others check the solution (convergence, glabella placed, nose not
mirrored).
"""

from __future__ import annotations

import numpy as np

from naseview.case import Case
from naseview.errors import NaseviewError
from naseview.landmarks import ALL_VIEWS, LANDMARK_IDS
from naseview.stage1_landmarks.frame import PAIR_BASES
from naseview.stage1_landmarks.params import SfmParams
from naseview.stage1_landmarks.problem import Problem
from naseview.stage1_landmarks.template import (
    TEMPLATE_MM,
    plausible_distance,
    typical_distance_mm,
)


class MirroredError(NaseviewError):
    """The adjusted nose is mirrored (pronasale behind glabella)."""


def case_file(case: Case) -> str:
    """The file the errors name: ``<case>/case.json``."""
    return str(case.root / "case.json")


def check_inputs(case: Case, params: SfmParams) -> None:
    """One-line errors for photos with too few or collinear clicks, left/right labels
    swapped, and a missing g."""
    for v in [v for v in ALL_VIEWS if v in case.views]:  # 4-6 photos, or a subset
        _check_clicks(case, v, params)
    for v, top in (("front", ("g", "n", "prn")), ("bottom", ("prn", "c"))):
        if v in case.views and sides_swapped(case.views[v].landmarks, top):
            raise NaseviewError(
                f"{case_file(case)}: key 'views.{v}.landmarks': in photo {v!r} the _l "
                "landmarks lie on the image left of their _r partners; _l/_r are the "
                f"subject's sides (the subject's left is on the image right in the {v} "
                "photo): swap the labels")
    if not any("g" in case.views[v].landmarks for v in case.views):
        raise NaseviewError(
            f"{case_file(case)}: key 'views.*.landmarks.g': glabella g (the origin of the 3D "
            "frame) is not clicked; click it in the front photo and in a profile photo")
    _check_scale_units(case)


def _check_scale_units(case: Case) -> None:
    """Every ``scale_mm`` distance a plausible one between its landmarks on a nose in mm
    (:func:`.template.plausible_distance`): another unit is an error, not a tiny nose."""
    for (a, b), d in case.scale_mm.items():
        if not plausible_distance(a, b, d):
            typical = (f" (typically about {typical_distance_mm(a, b):.0f} mm)"
                       if a in TEMPLATE_MM and b in TEMPLATE_MM else "")
            raise NaseviewError(
                f"{case_file(case)}: key 'scale_mm.{a}-{b}': {d:g} mm is not a distance "
                f"between these landmarks on a nose{typical}; give the calliper distance "
                "in millimetres (1 cm = 10 mm)")


def _check_clicks(case: Case, v: str, params: SfmParams) -> None:
    """Photo ``v`` has ``min_clicks_per_photo`` landmark clicks, not on one line."""
    where = case_file(case)
    view = case.views[v]
    ids = [i for i in view.landmarks if i in LANDMARK_IDS]
    if len(ids) < params.min_clicks_per_photo:
        raise NaseviewError(
            f"{where}: key 'views.{v}.landmarks': only {len(ids)} landmark clicks in "
            f"photo {v!r}; click at least {params.min_clicks_per_photo} of the 21 "
            "landmarks in every photo")
    P = np.array([view.landmarks[i] for i in ids])
    sv = np.linalg.svd(P - P.mean(0), compute_uv=False)
    if sv[0] <= 0 or sv[1] / sv[0] < params.min_spread_ratio:
        raise NaseviewError(
            f"{where}: key 'views.{v}.landmarks': the clicks in photo {v!r} lie on one "
            "line; check that they were placed on this photo (they must spread over "
            "the nose)")


def sides_swapped(clicks: dict[str, np.ndarray], top: tuple[str, ...]) -> bool:
    """True when most left/right pairs are mirrored in a photo facing the subject.

    "Up" in the photo is from ``sn`` to the first available of ``top``; the subject's left
    is then 90 degrees clockwise of it on screen (image right when upright), whatever the
    roll of the photo. Needs ``sn`` and two pairs; otherwise False.

    Args:
        clicks: id -> (2,) px.
    """
    up_id = next((i for i in top if i in clicks), None)
    if "sn" not in clicks or up_id is None:
        return False
    u = clicks[up_id] - clicks["sn"]
    left = np.array([-u[1], u[0]])  # image y points down
    votes = [float(np.sign((clicks[b + "_l"] - clicks[b + "_r"]) @ left))
             for b in PAIR_BASES if b + "_l" in clicks and b + "_r" in clicks]
    return len(votes) >= 2 and sum(votes) < 0


def check_shared_clicks(case: Case, views: list[str], point_ids: list[str]) -> None:
    """Every photo has 4+ clicks of landmarks also clicked in another photo."""
    for v in views:
        n = sum(1 for lid in point_ids if lid in case.views[v].landmarks)
        if n < 4:
            raise NaseviewError(
                f"{case_file(case)}: key 'views.{v}.landmarks': only {n} clicks in photo "
                f"{v!r} are also clicked in another photo; at least 4 shared landmarks are "
                "needed to place this camera")


def check_scale(case: Case, placed: set[str]) -> None:
    """A ``scale_mm`` distance joins two of the ``placed`` landmarks."""
    usable = [(a, b) for (a, b) in case.scale_mm if a in placed and b in placed]
    if not usable:
        keys = ", ".join(f"{a}-{b}" for a, b in case.scale_mm)
        missing = sorted({i for pair in case.scale_mm for i in pair} - placed)
        raise NaseviewError(
            f"{case_file(case)}: key 'scale_mm': no scale distance ({keys}) can be used "
            f"because {', '.join(missing)} could not be reconstructed; click these "
            "landmarks in at least two photos or give a distance between reconstructed "
            "landmarks (e.g. al_l-al_r)")


def check_fit(case: Case, prob: Problem, res_norm: np.ndarray, inlier_rmse: float,
              suspect: np.ndarray, params: SfmParams) -> None:
    """The inlier RMSE (px) and the fraction of suspect clicks are within bounds, else an
    error naming the worst photo and its worst click.

    Args:
        res_norm, suspect: (M,) click residuals (px) and suspect mask.
    """
    if not (inlier_rmse > params.max_rmse_px
            or suspect.mean() > params.max_suspect_fraction):
        return
    per_view = [float(np.sqrt(np.mean(res_norm[prob.obs_view == i] ** 2)))
                for i in range(prob.n_views)]
    wv = int(np.argmax(per_view))
    worst = int(np.argmax(np.where(prob.obs_view == wv, res_norm, -1.0)))
    v = prob.views[wv]
    raise NaseviewError(
        f"{case_file(case)}: key 'views.{v}.landmarks': bundle adjustment did not converge "
        f"(reprojection RMSE {inlier_rmse:.1f} px; worst photo {v!r}, worst click "
        f"{prob.point_ids[prob.obs_point[worst]]!r} at {res_norm[worst]:.1f} px); check the "
        "clicks of that photo and that _l/_r mean the subject's left/right")


def check_glabella(case: Case, landmarks: dict[str, np.ndarray],
                   seen_in: dict[str, list[str]]) -> None:
    """Glabella g, the origin, is among the placed landmarks."""
    if "g" not in landmarks:
        raise NaseviewError(
            f"{case_file(case)}: key 'views.*.landmarks.g': glabella g (the origin) could "
            f"not be placed from photo(s) {', '.join(seen_in['g']) or 'none'}; click it in "
            "the front photo and in a profile photo")


def check_not_mirrored(case: Case, landmarks: dict[str, np.ndarray]) -> None:
    """Pronasale lies in front of glabella (+z), else :class:`MirroredError`."""
    if "prn" in landmarks and landmarks["prn"][2] <= 0:
        raise MirroredError(
            f"{case_file(case)}: key 'views.*.landmarks': the nose comes out mirrored "
            "(pronasale behind glabella); left/right labels look swapped: _l is the "
            "subject's left, on the image right in the front photo")


def gauge_error(case: Case, reason: ValueError) -> NaseviewError:
    """The error when the adjusted landmarks cannot define the SPEC frame."""
    return NaseviewError(
        f"{case_file(case)}: key 'views': cannot set up the 3D frame ({reason}); click g, "
        "n, sn and at least one left/right pair (e.g. al_l and al_r) in two photos each")


def no_rig_error(case: Case) -> NaseviewError:
    """The error when no rig hypothesis gives cameras with the nose in front."""
    return NaseviewError(
        f"{case_file(case)}: key 'views': no camera arrangement fits the clicks; check that "
        "each photo's clicks belong to that photo (front, left, right, bottom)")


def swapped_profiles_error(case: Case) -> NaseviewError:
    """The error when the left and right photos fit only on each other's side."""
    return NaseviewError(
        f"{case_file(case)}: key 'views.left.image': the photos of 'left' and 'right' look "
        "swapped (the camera of 'left' must be on the subject's left side); swap their "
        "image and landmarks in case.json")
