"""Sub-landmarks sampled on the boundary curves; with the 21 landmarks, the ad-landmarks.

The paper samples sub-landmarks on the six boundary curves so that landmarks plus
sub-landmarks give 76 ad-landmarks (21 + 55), which drive the ARAP refinement of stage 3.
Here a curve's count is shared among its landmark-to-landmark segments in proportion to
their length; inside a segment the points are equally spaced in arc length. Each
ad-landmark carries a tag::

    {"id": "mid.03", "curve": "mid", "t": 0.41, "between": ["k", "r"], "s": 0.5}

``t`` is the arc-length fraction along the whole curve (along the loop from al'' for the
sills), ``between`` the two landmarks of the segment and ``s`` the fraction inside it.
Landmarks are tagged with their id and their place on the first curve through them.

Example
-------
>>> import numpy as np
>>> P = np.column_stack([np.linspace(0, 10, 11), np.zeros(11), np.zeros(11)])
>>> X, tags = sample_curve(P, [("a", 0), ("b", 4), ("c", 10)], 3, "demo")
>>> X[:, 0].round(3).tolist(), [t["between"] for t in tags]
([2.0, 6.0, 8.0], [['a', 'b'], ['b', 'c'], ['b', 'c']])
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from itertools import pairwise
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from naseview.geometry.polyline import cumulative_length
from naseview.landmarks import CURVE_NAMES, LANDMARK_IDS, LANDMARKS


def _share(lengths: np.ndarray, count: int) -> np.ndarray:
    """Largest-remainder split of ``count`` in proportion to ``lengths``."""
    if count <= 0 or len(lengths) == 0:
        return np.zeros(len(lengths), int)
    w = lengths / lengths.sum() if lengths.sum() > 0 else np.full(len(lengths), 1 / len(lengths))
    raw = w * count
    k = np.floor(raw).astype(int)
    rest = count - int(k.sum())
    k[np.argsort(-(raw - k))[:rest]] += 1
    return k


def _at(P: np.ndarray, s: np.ndarray, target: np.ndarray) -> np.ndarray:
    return np.stack([np.interp(target, s, P[:, j]) for j in range(P.shape[1])], axis=1)


def _sample_loop(P: np.ndarray, anchors: Sequence[tuple[str, int]], count: int,
                 name: str) -> tuple[np.ndarray, list[dict[str, Any]]]:
    """``count`` points equally spaced around a closed loop (N, 3) from its anchor."""
    start = anchors[0][1] if anchors else 0
    Q = np.roll(P, -start, axis=0)
    Q = np.vstack([Q, Q[:1]])
    s = cumulative_length(Q)
    t = np.arange(1, count + 1) / (count + 1)
    lid = anchors[0][0] if anchors else None
    tags: list[dict[str, Any]] = [{"id": f"{name}.{i:02d}", "curve": name, "t": float(ti),
                                   "between": [lid, lid], "s": float(ti)}
                                  for i, ti in enumerate(t)]
    return _at(Q, s, t * s[-1]), tags


def _sample_open(P: np.ndarray, anchors: Sequence[tuple[str, int]], count: int,
                 name: str) -> tuple[np.ndarray, list[dict[str, Any]]]:
    """``count`` points on an open curve (N, 3), shared among its anchor-to-anchor
    segments by length, equally spaced inside each."""
    s = cumulative_length(P)
    total = s[-1] if s[-1] > 0 else 1.0
    if len(anchors) < 2:
        anchors = [("", 0), ("", len(P) - 1)]
    seg_len = np.array([s[b[1]] - s[a[1]] for a, b in pairwise(anchors)])
    ks = _share(np.maximum(seg_len, 0.0), count)
    out = []
    tags: list[dict[str, Any]] = []
    for ((la, ia), (lb, ib)), k in zip(pairwise(anchors), ks, strict=True):
        for j in range(k):
            frac = (j + 1) / (k + 1)
            sv = s[ia] + frac * (s[ib] - s[ia])
            out.append(sv)
            tags.append({"id": f"{name}.{len(tags):02d}", "curve": name,
                         "t": float(sv / total), "between": [la, lb], "s": float(frac)})
    return _at(P, s, np.array(out)), tags


def sample_curve(P: ArrayLike, anchors: Sequence[tuple[str, int]], count: int, name: str,
                 closed: bool = False) -> tuple[np.ndarray, list[dict[str, Any]]]:
    """Sub-landmarks on one curve.

    Args:
        P: (N, 3) polyline (mm); closed loops without the first point repeated.
        anchors: (landmark id, index into P) in curve order; for a closed loop one anchor
            (al'') at which the loop starts.
        count: number of sub-landmarks.
        name: curve name for the tags.
        closed: P is a loop.
    Returns:
        (count, 3) positions and ``count`` tags (see the module docstring).
    """
    P = np.asarray(P, dtype=np.float64)
    if count <= 0 or len(P) < 2:
        return np.zeros((0, 3)), []
    return (_sample_loop if closed else _sample_open)(P, anchors, count, name)


def landmark_tag(lid: str, anchors: Mapping[str, Sequence[tuple[str, int]]],
                 curves: Mapping[str, np.ndarray]) -> dict[str, Any]:
    """Tag of a landmark: its id and its place on the first curve through it."""
    for cname in LANDMARKS[lid].curves:
        for a, idx in anchors.get(cname, ()):
            if a == lid and cname in curves and len(curves[cname]) > 1:
                s = cumulative_length(curves[cname])
                t = 0.0 if cname.startswith("sill") else float(s[idx] / max(s[-1], 1e-12))
                return {"id": lid, "curve": cname, "t": t, "between": [lid, lid], "s": 0.0}
    first = LANDMARKS[lid].curves[0] if LANDMARKS[lid].curves else None
    return {"id": lid, "curve": first, "t": None, "between": [lid, lid], "s": 0.0}


def ad_landmarks(landmarks: Mapping[str, ArrayLike], curves: Mapping[str, np.ndarray],
                 anchors: Mapping[str, Sequence[tuple[str, int]]],
                 counts: Mapping[str, int]) -> tuple[np.ndarray, list[dict[str, Any]]]:
    """The ad-landmarks: the 21 landmarks, then the sub-landmarks curve by curve.

    Args:
        landmarks: id -> (3,) stage-1 landmarks (mm); missing ids are skipped.
        curves: curve name -> (N, 3) polylines (SPEC §5 names).
        anchors: curve name -> [(landmark id, index into the curve)] in curve order.
        counts: sub-landmarks per curve (CurveParams.sub_landmarks).
    Returns:
        (M, 3) positions (M = 76 with all landmarks and the default counts) and M tags.
    """
    X: list[np.ndarray] = []
    tags: list[dict[str, Any]] = []
    for lid in LANDMARK_IDS:
        if lid in landmarks:
            X.append(np.asarray(landmarks[lid], dtype=np.float64).reshape(1, 3))
            tags.append(landmark_tag(lid, anchors, curves))
    for cname in CURVE_NAMES:
        k = int(counts.get(cname, 0))
        if k <= 0 or cname not in curves:
            continue
        Xc, tc = sample_curve(curves[cname], anchors.get(cname, []), k, cname,
                              closed=cname.startswith("sill"))
        X.append(Xc)
        tags += tc
    return (np.vstack(X) if X else np.zeros((0, 3))), tags
