"""The face around the profile band bent onto the profile silhouettes before ARAP (issue 23).

The fit leaves the upper lip and the glabella partly the model's: a base too coarse to
follow the profile photos in its fit (the generic face, 9 modes) keeps a lip 3-5 mm
forward of james's and lps's (nasolabial angle 29-39° off), and even the ICT fit, which
matches the band, keeps its lip's shape between the matches. Before ARAP the face
around the band outside the nose (:func:`~naseview.stage3_mesh.profile_band.profile_band`
with ``params.band_warp_half_width_mm``, wider than the matched band so the lip's outline
is not simply taken over by the unmoved cheek beside it; minus the model's nose) is bent
smoothly onto the photos' silhouettes, a few rounds of

1. the occluding contour of the band and the nose matched to each profile photo's
   silhouette (:func:`~naseview.stage3_mesh.silhouette.contour_targets`, each match at
   most ``params.band_warp_max_mm``; the camera's shift, found over the nose and the
   band together, taken out); the band's matches are kept, and a vertex matched in an
   earlier round keeps its match (the contour found behind it next round would
   otherwise drag it on past the silhouette);
2. the soft bi-Laplacian warp of :func:`~naseview.stage3_mesh.warp.smooth_warp` of the
   base towards all the matches so far, each of weight ``1 / fit_silhouette_sigma_mm^2``,
   zero outside the band (the nose is not moved: its handles shape it).

Measured (``benchmarks/bench_real.py --sets real``; james-a, james-b, lps-a, lps-b;
before -> after):

- generic base: nose surface mean 0.843 / 0.975 / 1.171 / 1.290 -> 0.803 / 0.954 / 1.115 /
  1.274 mm; nasolabial angle error -34 / -39 / -37 / -29° -> +11 / -1 / 0 / 0°;
- ICT base: surface 0.735 / 0.921 / 0.847 / 1.224 -> 0.737 / 0.922 / 0.889 / 1.181 mm
  (mean 0.932 both); nasolabial -> +2.2 / -3.2 / -1.4 / -9.4° from +3.4 / +3.5 / -8.2 /
  -12.6°.

SPEC frame, mm.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from naseview.facemodel import FaceModel
from naseview.stage3_mesh.params import RefineParams
from naseview.stage3_mesh.profile_band import profile_band
from naseview.stage3_mesh.silhouette import Silhouette, contour_targets, edge_faces, same_matches
from naseview.stage3_mesh.warp import smooth_warp


def band_warp(model: FaceModel, base: np.ndarray, landmarks: Mapping[str, np.ndarray],
              silhouettes: Sequence[Silhouette], params: RefineParams) -> np.ndarray:
    """The base face with its profile band bent onto the profile silhouettes.

    Args:
        model: the face model (its faces and nose vertices).
        base: (n, 3) the warped base face, mm, SPEC frame.
        landmarks: id -> (3,) mm (g or n, and sn, place the band).
        silhouettes: the photos' silhouettes; the profile ones (``outline``) are matched.
        params: ``band_warp_rounds``, ``band_warp_max_mm``, the band's reach, the
            silhouette spacing and ``warp_bending_mm2``.
    Returns:
        (n, 3) mm: ``base`` with the band outside the nose moved (module docstring);
        ``base`` itself without a band, a profile silhouette or a round.
    """
    profiles = [s for s in silhouettes if s.outline]
    F = np.asarray(model.faces, np.int64)
    nose = np.zeros(len(base), bool)
    nose[np.asarray(model.nose_vertices, np.int64)] = True
    band = profile_band(base, landmarks, params.profile_above_g_mm,
                        params.profile_below_sn_mm, params.band_warp_half_width_mm) & ~nose
    if not profiles or not band.any() or not params.band_warp_rounds:
        return base
    region = np.flatnonzero(band)
    ed = edge_faces(F)
    out = base
    held: dict[int, np.ndarray] = {}
    last: tuple[np.ndarray, np.ndarray] | None = None
    for _ in range(params.band_warp_rounds):
        ids, tg, _ = contour_targets(out, F, profiles, band | nose, np.zeros((0, 3)),
                                     params.silhouette_spacing_mm, params.band_warp_max_mm,
                                     ed, params.silhouette_detrend)
        keep = band[ids]
        ids, tg = ids[keep], tg[keep]
        if not len(ids) or same_matches(ids, tg, last):
            break
        last = (ids, tg)
        held.update({int(i): t for i, t in zip(ids, tg, strict=True)})
        hv = np.fromiter(held, np.int64, len(held))
        ht = np.array([held[int(i)] for i in hv]).reshape(-1, 3)
        out = smooth_warp(base, F, hv, ht,
                          np.full(len(hv), 1.0 / params.fit_silhouette_sigma_mm ** 2),
                          params.warp_bending_mm2, region)
    return out
