"""Where a sub-landmark sits on a face model's mesh curve: an arc-length fraction (§3.4).

The paper makes each ad-landmark a handle of the base mesh (eq. 19-20). For the 21
landmarks the model names the vertex; a sub-landmark of stage 2 (§3.3) is known only by
the curve it lies on and its arc-length fraction, so stage 3 finds the same fraction along
the model's vertex path of that curve (``FaceModel.curve_vertices``):

- :func:`curve_path_segment` - the part of a mesh curve a fraction is measured along;
- :func:`arclength_point` - where a fraction of a polyline's length falls;
- :func:`sub_rows` - stage 2's tags read into :class:`SubRow` (curve, segment, fraction,
  target);
- :func:`sub_positions` - each row's point on a mesh, as two vertices and a weight;
- :func:`orient_loops` - the direction round a closed curve (the nasal sills) that fits.

Used by the base fit (:mod:`~naseview.stage3_mesh.fit`) and the handles
(:mod:`~naseview.stage3_mesh.correspondences`). SPEC frame, mm.

Example
-------
>>> import numpy as np
>>> arclength_point(np.array([[0.0, 0, 0], [1, 0, 0], [3, 0, 0]]), 0.5)
(1, 2, 0.25)
"""

from __future__ import annotations

import numbers
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from naseview.facemodel import FaceModel
from naseview.landmarks import CURVE_LANDMARKS, LANDMARK_IDS

AdLandmarkTag = Mapping[str, object]
"""One of stage 2's ad-landmark tags (:mod:`naseview.stage2_curves.sublandmarks`):
``{"id", "curve", "t", "between", "s"}`` with ``t`` the fraction along the whole curve,
``between`` the segment's two landmark ids and ``s`` the fraction inside that segment."""

Segment = tuple[str, str]
"""``(a, b)`` landmark ids bounding the part of a curve a fraction is measured along."""


def _path_index(path: np.ndarray, model: FaceModel, lm: str) -> int | None:
    """Index in ``path`` of landmark ``lm``'s vertex (None: not on the path)."""
    hit = np.flatnonzero(path == model.landmark_vertices.get(lm, -1))
    return int(hit[0]) if len(hit) else None


def _first_landmark_index(path: np.ndarray, model: FaceModel, curve: str) -> int | None:
    """Index of the first of the curve's SPEC landmarks that lies on ``path``."""
    for lm in CURVE_LANDMARKS.get(curve, ()):
        i = _path_index(path, model, lm)
        if i is not None:
            return i
    return None


def _loop_segment(path: np.ndarray, model: FaceModel, curve: str,
                  segment: Segment | None, reverse: bool) -> np.ndarray:
    """A closed curve from ``segment[0]``'s vertex (else its first landmark) round to it."""
    start = _path_index(path, model, segment[0]) if segment is not None else None
    if start is None:
        start = _first_landmark_index(path, model, curve)
    loop = np.roll(path, -(start or 0))
    if reverse:
        loop = np.r_[loop[:1], loop[1:][::-1]]
    return np.r_[loop, loop[:1]]


def _open_segment(path: np.ndarray, model: FaceModel, curve: str,
                  segment: Segment | None) -> np.ndarray:
    """An open curve from ``segment[0]`` to ``segment[1]``, else whole in SPEC order."""
    if segment is not None and segment[0] != segment[1]:
        a, b = _path_index(path, model, segment[0]), _path_index(path, model, segment[1])
        if a is not None and b is not None:
            return path[a:b + 1] if a <= b else path[b:a + 1][::-1]
    return _in_spec_order(path, model, curve)


def _in_spec_order(path: np.ndarray, model: FaceModel, curve: str) -> np.ndarray:
    """The whole open curve, reversed if its landmarks run against the SPEC order."""
    order = [i for i in (_path_index(path, model, lm) for lm in CURVE_LANDMARKS.get(curve, ()))
             if i is not None]
    if len(order) >= 2 and order[0] > order[-1]:
        return path[::-1]
    return path


def curve_path_segment(path: np.ndarray, model: FaceModel, curve: str,
                       segment: Segment | None, reverse: bool = False) -> np.ndarray:
    """The part of a mesh curve that a fraction is measured along, in increasing order.

    Args:
        path: (L,) vertex ids of ``model.curve_vertices[curve]``.
        model: the face model (its ``landmark_vertices``).
        curve: SPEC §5 curve name; ``sill_*`` are closed loops.
        segment: ``(a, b)`` landmark ids: the part of the path from a's vertex to b's;
            ``(a, a)`` on a closed curve: the whole loop starting and ending at a's vertex;
            ``None`` (or landmarks not on the path): the whole curve, oriented in the SPEC
            order of its landmarks (:data:`~naseview.landmarks.CURVE_LANDMARKS`); a loop
            then starts at its landmark (al'').
        reverse: run a closed loop the other way round.
    Returns:
        (L',) vertex ids; a loop ends with its first vertex repeated.
    """
    path = np.asarray(path, np.int64)
    if curve.startswith("sill"):
        return _loop_segment(path, model, curve, segment, reverse)
    return _open_segment(path, model, curve, segment)


def arclength_point(P: np.ndarray, t: float) -> tuple[int, int, float]:
    """Where fraction ``t`` of the arc length of the polyline ``P`` (L, 3) falls.

    Returns:
        ``(i, j, a)``: the point is ``(1 - a) * P[i] + a * P[j]`` with ``j = i + 1``
        (``i == j`` for a single point).
    """
    if len(P) == 1:
        return 0, 0, 0.0
    seg = np.linalg.norm(np.diff(P, axis=0), axis=1)
    cum = np.r_[0.0, np.cumsum(seg)]
    s = float(np.clip(t, 0.0, 1.0)) * cum[-1]
    i = int(np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(P) - 2))
    a = 0.0 if seg[i] <= 0 else float(np.clip((s - cum[i]) / seg[i], 0.0, 1.0))
    return i, i + 1, a


@dataclass
class SubRow:
    """A sub-landmark's place on its mesh curve: fraction ``frac`` along
    :func:`curve_path_segment` ``(curve, segment, reverse)``; ``target`` (3,) mm is the
    sub-landmark itself. ``reverse`` is chosen by :func:`orient_loops`."""

    name: str
    curve: str
    frac: float
    segment: Segment | None
    target: np.ndarray
    reverse: bool = False


def _tag_segment(tag: AdLandmarkTag) -> Segment | None:
    """The tag's ``between`` pair of landmark ids, when it has two non-empty ones."""
    seg = tag.get("between")
    if isinstance(seg, (list, tuple)) and len(seg) == 2 and seg[0] and seg[1]:
        return str(seg[0]), str(seg[1])
    return None


def _tag_fraction(tag: AdLandmarkTag, segment: Segment | None) -> float | None:
    """The fraction a tag gives: ``s`` inside its segment when it has one, else ``t``."""
    frac = tag.get("s") if segment is not None and tag.get("s") is not None else tag.get("t")
    return float(frac) if isinstance(frac, numbers.Real) else None


def sub_rows(model: FaceModel, ad_landmarks: np.ndarray | None,
             tags: Sequence[AdLandmarkTag] | None,
             curves: Sequence[str] | None = None) -> tuple[list[SubRow], list[str]]:
    """Stage 2's sub-landmarks as rows (the 21 landmarks among the ad-landmarks skipped).

    The segment form of a tag (``between`` and ``s``) is used when present. Only curves in
    ``curves`` are used (``None``: all); curves the model has no path for are skipped with
    one warning.

    Args:
        model: the face model (its ``curve_vertices``).
        ad_landmarks: (M, 3) stage 2's ad-landmarks, mm; tags: their M tags.
        curves: SPEC §5 curve names to use.
    Returns:
        ``(rows, warnings)``.
    """
    if ad_landmarks is None or tags is None:
        return [], []
    ad = np.asarray(ad_landmarks, np.float64).reshape(-1, 3)
    if len(tags) != len(ad):
        return [], [f"reconstruction: {len(ad)} ad_landmarks but {len(tags)} "
                    "ad_landmark_tags; sub-landmarks not used"]
    rows: list[SubRow] = []
    missing: set[str] = set()
    for p, tag in zip(ad, tags, strict=True):
        row = _sub_row(model, p, tag, curves, missing)
        if row is not None:
            rows.append(row)
    warnings = [f"face model '{model.name}' has no mesh curve {sorted(missing)}; "
                "their sub-landmarks are not used"] if missing else []
    return rows, warnings


def _sub_row(model: FaceModel, p: np.ndarray, tag: object, curves: Sequence[str] | None,
             missing: set[str]) -> SubRow | None:
    """One ad-landmark as a row, or None (a landmark, unusable, or a curve not used);
    a curve the model lacks is added to ``missing``."""
    if not isinstance(tag, Mapping) or not np.isfinite(p).all():
        return None
    if tag.get("id") in LANDMARK_IDS:
        return None  # one of the 21: taken from reconstruction.landmarks
    curve = tag.get("curve")
    if curve is None or (curves is not None and curve not in curves):
        return None
    segment = _tag_segment(tag)
    frac = _tag_fraction(tag, segment)
    if frac is None:
        return None
    if not _has_path(model, str(curve)):
        missing.add(str(curve))
        return None
    return SubRow(str(tag.get("id") or f"{curve}@{frac:.3f}"), str(curve), frac, segment, p)


def _has_path(model: FaceModel, curve: str) -> bool:
    """The model has a vertex path of at least two vertices for ``curve``."""
    return curve in model.curve_vertices and len(model.curve_vertices[curve]) >= 2


def sub_positions(model: FaceModel, V: np.ndarray, rows: Sequence[SubRow]
                  ) -> list[tuple[int, int, float]]:
    """For each row, ``(i, j, a)``: its point on mesh ``V`` (n, 3) is (1-a) V[i] + a V[j].

    Rows on the same curve segment share one path (:func:`curve_path_segment`); the
    fraction is measured along that path on ``V`` (:func:`arclength_point`).
    """
    out: list[tuple[int, int, float]] = [(0, 0, 0.0)] * len(rows)
    groups: dict[tuple[str, Segment | None, bool], list[int]] = {}
    for k, r in enumerate(rows):
        groups.setdefault((r.curve, r.segment, r.reverse), []).append(k)
    for (curve, segment, reverse), ks in groups.items():
        path = curve_path_segment(model.curve_vertices[curve], model, curve, segment, reverse)
        P = V[path]
        for k in ks:
            i, j, a = arclength_point(P, rows[k].frac)
            out[k] = (int(path[i]), int(path[j]), a)
    return out


def _loop_cost(model: FaceModel, V: np.ndarray, group: Sequence[SubRow], reverse: bool
               ) -> float:
    """Sum of squared distances (mm^2) of one closed curve's rows to their targets when
    measured the ``reverse`` way round. Sets ``reverse`` on the rows."""
    for r in group:
        r.reverse = reverse
    pts = [(1 - a) * V[i] + a * V[j] for i, j, a in sub_positions(model, V, group)]
    return sum(float(np.sum((q - r.target) ** 2)) for q, r in zip(pts, group, strict=True))


def orient_loops(model: FaceModel, V: np.ndarray, rows: Sequence[SubRow]) -> None:
    """Choose, per closed curve, the direction round the mesh loop that puts the
    sub-landmarks nearest their targets (``V`` (n, 3) in the targets' frame). In place."""
    for curve in sorted({r.curve for r in rows if r.curve.startswith("sill")}):
        group = [r for r in rows if r.curve == curve]
        cost = [_loop_cost(model, V, group, rev) for rev in (False, True)]
        for r in group:
            r.reverse = cost[1] < cost[0]
