"""UV parametrisation of a face mesh: one chart, conformal, with the nose magnified.

The texture of a face needs each vertex of the face mesh ``V`` (n, 3) mm, ``F`` (m, 3), at
a point ``uv`` (n, 2) of the texture square. One chart without cuts keeps the vertex ids of
the mesh (a vertex has one ``uv``): the free-boundary least-squares conformal map (LSCM,
Lévy et al. 2002, ``igl.lscm``) of the whole face with its eye and mouth holes closed for
the map (ear-clipped in each hole's plane, :func:`naseview.geometry.closing.ear_clip`; a
hole whose flat cap would fold the chart, like ICT's mouth, stays free). Left free, a
hole's border is squeezed by the map (an ICT eye socket's 24 x 16 mm opening became
76 x 17 texels, a third of the vertical resolution), and the cap a renderer puts over it
is textured in streaks. A conformal map of a head-like bowl shrinks its
centre, the nose, which is what the surgeon and the patient look at; a radial warp of the
chart around the nose (``r -> log(1 + k r) / log(1 + k)``, monotone, so no triangle folds)
magnifies it about ``k / log(1 + k)`` times. The chart is turned so that the face's up
(+y) points up in the texture image, scaled uniformly into ``[margin, 1 - margin]^2``.

Convention: ``uv = (u, v)`` in [0, 1]; texel column ``x = u W - 0.5``, row
``y = v H - 0.5`` (origin at the image's top-left, v down: glTF's convention).

The map depends only on the topology in practice (every face of a face model shares it and
edits move vertices, not the chart), so it is computed once per ``F`` and cached by a hash
of ``F``'s bytes: later calls with the same triangles return the same chart, whatever ``V``.

Example
-------
>>> import numpy as np
>>> gx, gy = np.meshgrid(np.linspace(-50, 50, 11), np.linspace(-50, 50, 11))
>>> V = np.c_[gx.ravel(), gy.ravel(), -0.01 * (gx.ravel() ** 2 + gy.ravel() ** 2)]
>>> i = np.arange(121).reshape(11, 11)
>>> F = np.r_[np.c_[i[:-1, :-1].ravel(), i[:-1, 1:].ravel(), i[1:, 1:].ravel()],
...           np.c_[i[:-1, :-1].ravel(), i[1:, 1:].ravel(), i[1:, :-1].ravel()]]
>>> uv = face_uv(V, F)
>>> bool(uv.min() >= 0.0 and uv.max() <= 1.0), bool(uv[i[-1, 5], 1] < uv[i[0, 5], 1])
(True, True)
"""

from __future__ import annotations

import hashlib
import threading

import igl
import numpy as np
from numpy.typing import ArrayLike

from naseview.errors import NaseviewError
from naseview.geometry.closing import boundary_loops, ear_clip

__all__ = ["face_uv", "flipped_triangles", "uv_to_pixels"]

_CACHE: dict[tuple[str, int, float, float], np.ndarray] = {}
_LOCK = threading.Lock()


def _key(F: np.ndarray, focus: int, magnify: float, margin: float
         ) -> tuple[str, int, float, float]:
    return (hashlib.sha1(np.ascontiguousarray(F, dtype=np.int64).tobytes()).hexdigest(),
            int(focus), float(magnify), float(margin))


def _signed_areas(uv: np.ndarray, F: np.ndarray) -> np.ndarray:
    a = uv[F[:, 1]] - uv[F[:, 0]]
    b = uv[F[:, 2]] - uv[F[:, 0]]
    return 0.5 * (a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])


def flipped_triangles(uv: ArrayLike, F: ArrayLike) -> np.ndarray:
    """(m,) bool: triangles whose orientation in the chart is opposite to the majority's."""
    A = _signed_areas(np.asarray(uv, np.float64), np.asarray(F, np.int64))
    return np.asarray(A * np.sign(A.sum()) < 0)


def _lscm(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """(n, 2) free-boundary LSCM, pinned at the two farthest vertices of the outer border."""
    loops = boundary_loops(F)
    if not loops:
        raise NaseviewError("face mesh: it has no border, so it cannot be flattened into a "
                            "texture; pass an open face mesh")
    outer = max(loops, key=lambda lp: float(np.linalg.norm(
        V[lp] - np.roll(V[lp], -1, axis=0), axis=1).sum()))
    P = V[outer]
    i = int(np.argmax(np.linalg.norm(P - P.mean(axis=0), axis=1)))
    j = int(np.argmax(np.linalg.norm(P - P[i], axis=1)))
    b = np.array([outer[i], outer[j]], dtype=np.int64)
    bc = np.array([[0.0, 0.0], [1.0, 0.0]])
    try:
        uv = np.asarray(igl.lscm(V, F, b, bc)[0], dtype=np.float64)
    except (RuntimeError, ValueError):
        uv = np.zeros((0, 2))
    if uv.shape != (len(V), 2) or not np.isfinite(uv).all():
        raise NaseviewError("face mesh: the conformal map failed (is the mesh one connected "
                            "piece with a border?)")
    return uv


def _flat_cap(V: np.ndarray, loop: np.ndarray) -> np.ndarray:
    """Triangles closing the hole ``loop`` (ear-clipped in its best-fit plane, no new
    vertex), oriented like the mesh: the rim runs ``loop[i] -> loop[i+1]`` in ``F``, so
    the cap runs it the other way."""
    P = V[loop] - V[loop].mean(axis=0)
    axes = np.linalg.svd(P, full_matrices=False)[2]
    T = loop[ear_clip(P @ axes[:2].T)]
    a, b = int(loop[0]), int(loop[1])
    if any((t[k], t[(k + 1) % 3]) == (a, b) for t in T.tolist() for k in range(3)):
        T = T[:, ::-1]
    return np.asarray(T, dtype=np.int64)


def _lscm_holes_closed(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """:func:`_lscm` of ``F`` with its holes (every border loop but the longest) closed
    for the map, one by one, each kept only if it folds no more triangles of ``F`` in the
    chart (an ICT eye opening is kept closed; its mouth, whose flat cap would fold the
    lips' corners, stays free)."""
    loops = sorted(boundary_loops(F), key=lambda lp: float(np.linalg.norm(
        V[lp] - np.roll(V[lp], -1, axis=0), axis=1).sum()))
    faces = F
    uv = _lscm(V, faces)
    folds = int(flipped_triangles(uv, F).sum())
    for loop in loops[:-1]:
        trial = np.concatenate([faces, _flat_cap(V, loop)])
        uv_t = _lscm(V, trial)
        n = int(flipped_triangles(uv_t, F).sum())
        if n <= folds:
            faces, uv, folds = trial, uv_t, n
    return uv


def _upright(uv: np.ndarray, V: np.ndarray) -> np.ndarray:
    """``uv`` (n, 2) turned so that SPEC up (+y) is image up (-v) and mirrored if needed
    so that the subject's left (+x) is on the image's right, like a front photo."""
    A = np.column_stack([uv - uv.mean(axis=0), np.ones(len(uv))])
    grad = np.linalg.lstsq(A, V[:, 1] - V[:, 1].mean(), rcond=None)[0][:2]
    ang = np.arctan2(grad[1], grad[0])
    target = -np.pi / 2                      # up in the image is -v
    c, s = np.cos(target - ang), np.sin(target - ang)
    rot = np.array([[c, -s], [s, c]])
    out = (uv - uv.mean(axis=0)) @ rot.T
    # the texture image reads like a front photo: the subject's left (+x) on the right
    if np.corrcoef(out[:, 0], V[:, 0])[0, 1] < 0:
        out[:, 0] = -out[:, 0]
    return out


def face_uv(V: ArrayLike, F: ArrayLike, focus: int | None = None, magnify: float = 6.0,
            margin: float = 0.02) -> np.ndarray:
    """Texture coordinates of a face mesh (cached per topology, see the module doc).

    Args:
        V: (n, 3) vertices (mm, SPEC frame: +y up, +z anterior).
        F: (m, 3) triangles, one connected piece with at least one border loop.
        focus: vertex magnified by the warp (default: the most anterior vertex, the nose
            tip of a face in the SPEC frame).
        magnify: warp strength ``k`` (0 = plain LSCM); the nose gets about
            ``k / log(1 + k)`` times the texels of the plain map.
        margin: empty border of the unit square (texture units).
    Returns:
        (n, 2) float64 ``uv`` in ``[margin, 1 - margin]`` (origin top-left, v down).
    Raises:
        NaseviewError: malformed arrays or a mesh that cannot be flattened.
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    if V.ndim != 2 or V.shape[1] != 3 or F.ndim != 2 or F.shape[1] != 3 or not len(F):
        raise NaseviewError(f"face mesh: expected (n, 3) vertices and (m, 3) triangles, got "
                            f"{V.shape} and {F.shape}")
    if F.min() < 0 or F.max() >= len(V) or not np.isfinite(V).all():
        raise NaseviewError("face mesh: triangles index missing vertices or vertices are "
                            "not finite")
    foc = int(np.argmax(V[:, 2])) if focus is None else int(focus)
    key = _key(F, -1 if focus is None else foc, magnify, margin)
    with _LOCK:
        hit = _CACHE.get(key)
    if hit is not None and len(hit) == len(V):
        return hit.copy()
    uv = _upright(_lscm_holes_closed(V, F), V)  # holes closed for the map (module doc)
    if magnify > 0:
        d = uv - uv[foc]
        r = np.linalg.norm(d, axis=1)
        R = float(r.max()) or 1.0
        k = float(magnify)
        scale = np.log1p(k * r / R) / np.log1p(k) * R / np.where(r > 0, r, 1.0)
        uv = uv[foc] + d * np.where(r > 0, scale, 1.0)[:, None]
    lo, hi = uv.min(axis=0), uv.max(axis=0)
    s = (1.0 - 2.0 * margin) / max(float((hi - lo).max()), 1e-12)
    uv = (uv - lo) * s + margin + 0.5 * ((1.0 - 2.0 * margin) - (hi - lo) * s)
    with _LOCK:
        _CACHE[key] = uv
    return uv.copy()


def uv_to_pixels(uv: ArrayLike, width: int, height: int) -> np.ndarray:
    """(n, 2) texel coordinates ``[x, y]`` (pixel centres at integers) of ``uv`` (n, 2)."""
    uv = np.asarray(uv, dtype=np.float64)
    return np.column_stack([uv[:, 0] * width - 0.5, uv[:, 1] * height - 0.5])
