"""Where the next landmark probably is, from the clicks so far: a pre-placed marker.

A surgeon needs about 5 s to find and click a landmark; confirming one already placed
near it takes about one. Before the photos can be related (the guidance bundle
adjustment, :mod:`naseview.intake.guidance`, needs two photos with six clicks each),
each photo is predicted on its own from the generic nose of stage 1
(:data:`naseview.stage1_landmarks.template.TEMPLATE_MM`, with the bottom view's ``add``
helpers halfway between ``alp`` and ``prn``):

- two or three clicks in the photo: a 2D similarity (scale, rotation, shift) of the
  template seen from the view's nominal direction
  (:func:`naseview.stage1_landmarks.plausibility.nominal_direction`);
- four or more: an affine camera of the 3D template (a 2x3 matrix and a shift), drawn
  towards that similarity (ridge) so that a few clicks cannot tilt it wildly;
- one click: the similarity's scale and rotation from a photo already fitted (photos of
  one patient are taken alike), shifted onto the click.

Once the guidance has placed the photo's camera, its reprojection is used instead
(:meth:`naseview.intake.guidance.Guidance.hints`). ``benchmarks/bench_annotation.py``
measures how far the prediction lands from the true click.

Example
-------
>>> import numpy as np
>>> lay = template_layout("front")
>>> clicks = {i: lay[i] * 10.0 + 400.0 for i in ("g", "n", "prn")}
>>> p = predict_view("front", clicks)["sn"]
>>> bool(np.allclose(p, lay["sn"] * 10.0 + 400.0))
True
"""

from __future__ import annotations

import math

import numpy as np

from naseview.intake.click_order import CLICK_ORDER
from naseview.stage1_landmarks.params import SfmParams
from naseview.stage1_landmarks.plausibility import nominal_direction
from naseview.stage1_landmarks.template import TEMPLATE_MM

RIDGE = 0.5
"""Weight of the similarity prior of the affine fit, per click (relative to one click's
squared error at the template's scale)."""


def _template_3d() -> dict[str, np.ndarray]:
    t = {k: np.asarray(v, np.float64) for k, v in TEMPLATE_MM.items()}
    for s in ("l", "r"):   # 2D helpers of the bottom outline, between alp and prn
        t[f"add_{s}"] = 0.5 * (t[f"alp_{s}"] + t["prn"]) + np.array([0.0, 0.0, 1.5])
    return t


TEMPLATE_3D = _template_3d()
"""id -> (3,) mm: the generic nose plus the bottom view's ``add`` helpers."""


def view_rotation(view: str) -> np.ndarray:
    """(3, 3) world -> camera rotation of the nominal ``view`` camera (rows: image right,
    image down, optical axis); the bottom photo shows the tip at the top."""
    d = nominal_direction(view, SfmParams().bottom_elevation_deg)
    up = np.array([0.0, 0.0, 1.0]) if view == "bottom" else np.array([0.0, 1.0, 0.0])
    down = -(up - (up @ d) * d)
    down /= np.linalg.norm(down)
    right = np.cross(down, d)
    return np.stack([right, down, d])


def template_layout(view: str) -> dict[str, np.ndarray]:
    """id -> (2,) the template seen from ``view`` (orthographic, mm, image axes)."""
    R = view_rotation(view)
    return {i: (R @ TEMPLATE_3D[i])[:2] for i in CLICK_ORDER[view]}


def fit_similarity(src: np.ndarray, dst: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """(scale, R (2, 2), t) minimising ``|s R src + t - dst|``, (N, 2) each, N >= 2."""
    ms, md = src.mean(0), dst.mean(0)
    a, b = src - ms, dst - md
    h = a.T @ b
    u, sv, vt = np.linalg.svd(h)
    d = np.sign(np.linalg.det(vt.T @ u.T)) or 1.0
    R = vt.T @ np.diag([1.0, d]) @ u.T
    var = float((a ** 2).sum())
    s = float((sv * [1.0, d]).sum() / var) if var > 0 else 1.0
    return s, R, md - s * R @ ms


def predict_view(view: str, clicks: dict[str, np.ndarray],
                 prior: tuple[float, np.ndarray] | None = None) -> dict[str, np.ndarray]:
    """id -> (2,) px predicted for every landmark of ``view`` not in ``clicks``.

    Args:
        view: the photo.
        clicks: id -> (2,) px clicked in it so far.
        prior: (scale px/mm, 2x2 rotation) of the similarity of a photo fitted before,
            used with a single click (see :func:`similarity_of`); ``None``: no prediction
            from one click.
    Returns:
        empty with no click (or one click and no ``prior``).
    """
    ids = [i for i in clicks if i in TEMPLATE_3D]
    todo = [i for i in CLICK_ORDER[view] if i not in clicks]
    if not ids or not todo:
        return {}
    lay = template_layout(view)
    dst = np.array([clicks[i] for i in ids], np.float64)
    if len(ids) == 1:
        if prior is None:
            return {}
        s, R = prior
        t = dst[0] - s * R @ lay[ids[0]]
        return {i: s * R @ lay[i] + t for i in todo}
    src = np.array([lay[i] for i in ids])
    s, R, t = fit_similarity(src, dst)
    if len(ids) < 4:
        return {i: s * R @ lay[i] + t for i in todo}
    # affine camera of the 3D template, drawn towards the similarity (ridge)
    Rv = view_rotation(view)
    P0 = s * R @ Rv[:2]                                   # (2, 3) of the similarity
    X = np.array([TEMPLATE_3D[i] for i in ids])
    xm = X.mean(0)
    Xc = X - xm
    Y = dst - dst.mean(0)
    lam = RIDGE * len(ids) * 100.0                        # ~ (10 mm)^2 per click
    A = Xc.T @ Xc + lam * np.eye(3)
    P = np.linalg.solve(A, Xc.T @ Y + lam * P0.T).T
    t3 = dst.mean(0) - P @ xm
    return {i: P @ TEMPLATE_3D[i] + t3 for i in todo}


def similarity_of(view: str, clicks: dict[str, np.ndarray]) -> tuple[float, np.ndarray] | None:
    """(scale, rotation) of the template similarity of a photo with 2+ clicks (a prior
    for another photo's first click), ``None`` otherwise."""
    ids = [i for i in clicks if i in TEMPLATE_3D]
    if len(ids) < 2:
        return None
    lay = template_layout(view)
    s, R, _ = fit_similarity(np.array([lay[i] for i in ids]),
                             np.array([clicks[i] for i in ids], np.float64))
    if not (math.isfinite(s) and s > 0):
        return None
    return s, R


def predict_next(view: str, clicks: dict[str, dict[str, np.ndarray]],
                 hints: dict[str, np.ndarray] | None = None) -> dict[str, np.ndarray]:
    """id -> (2,) px predicted in ``view`` for the landmarks not clicked there: the
    guidance reprojection ``hints`` where there is one, else the template fit of this
    photo's clicks (:func:`predict_view`, with the scale of another photo's fit for a
    first click)."""
    own = clicks.get(view, {})
    prior = None
    for v, c in clicks.items():
        if v != view and prior is None:
            sim = similarity_of(v, c)
            if sim is not None:
                prior = (sim[0], np.eye(2)) if v != view else sim
    out = predict_view(view, own, prior)
    for i, p in (hints or {}).items():
        if i not in own:
            out[i] = np.asarray(p, np.float64)
    return out


__all__ = ["TEMPLATE_3D", "fit_similarity", "predict_next", "predict_view",
           "similarity_of", "template_layout", "view_rotation"]
