"""Stand-ins for landmarks stage 1 could not place, so their curves can still be made.

A landmark clicked in one photo only has no 3D position from stage 1 (paper §3.2 needs
two views). For the curves (not as an ad-landmark) it is put on its line of sight in that
photo, at the camera depth of a reference landmark: its mirror partner when placed, else
the neighbours listed in :data:`DEPTH_REFS` (same side). Each stand-in gives a warning and
the curves through it are flagged ``"estimated"``.

Example
-------
>>> sorted(DEPTH_REFS["k"])
['n', 'r']
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from naseview.camera import Camera
from naseview.case import Case
from naseview.landmarks import LANDMARK_IDS, mirror_id
from naseview.stage2_curves.run import photo_label

DEPTH_REFS: dict[str, tuple[str, ...]] = {
    "mf": ("n",), "md": ("c", "alp"), "int": ("al",), "al": ("alp", "ac"), "alp": ("prn",),
    "alpp": ("alp",), "ac": ("al",), "n": ("g",), "k": ("n", "r"), "r": ("k", "prn"),
    "c": ("prn", "sn"), "sn": ("c",), "prn": ("r", "c"),
}
"""Landmarks whose camera depth stands in for a landmark stage 1 could not place."""

_SIDED: frozenset[str] = frozenset({"mf", "md", "int", "al", "alp", "alpp", "ac"})
"""Bases of :data:`DEPTH_REFS` that take the missing landmark's side suffix."""


def _references(lid: str, placed: Mapping[str, np.ndarray]) -> list[str]:
    """Placed landmarks whose depth stands in for ``lid``: its partner, else DEPTH_REFS."""
    base, side = (lid[:-2], lid[-2:]) if lid[-2:] in ("_l", "_r") else (lid, "")
    refs = [mirror_id(lid)] if mirror_id(lid) in placed else \
        [r + (side if r in _SIDED else "") for r in DEPTH_REFS.get(base, ())]
    return [r for r in refs if r in placed]


def _on_line_of_sight(cam: Camera, uv: np.ndarray, refs: list[np.ndarray]) -> np.ndarray:
    """(3,) point of pixel ``uv`` (2,) at the mean camera depth of the (3,) ``refs``."""
    C, d = cam.rays(uv[None])
    depth = float(np.mean(cam.depth(np.array(refs))))
    return np.asarray(C + d[0] * depth / float(d[0] @ cam.R[2]))


def stand_in_landmarks(case: Case, landmarks: Mapping[str, np.ndarray],
                       cameras: Mapping[str, Camera]
                       ) -> tuple[dict[str, np.ndarray], set[str], list[str]]:
    """Stage 1's landmarks plus a stand-in for each one it could not place.

    Args:
        case: the clicks.
        landmarks: stage 1's id -> (3,) mm.
        cameras: stage 1's view -> camera.
    Returns:
        id -> (3,) mm with the stand-ins added (in SPEC order, so a stand-in may serve as
        the reference of a later one), the ids of the stand-ins, and one warning each.
    """
    L3 = {k: np.asarray(v, dtype=np.float64) for k, v in landmarks.items()}
    estimated: set[str] = set()
    warnings: list[str] = []
    for lid in LANDMARK_IDS:
        if lid in L3:
            continue
        refs = _references(lid, L3)
        views = [v for v, vw in case.views.items() if lid in vw.landmarks and v in cameras]
        if not refs or not views:
            continue
        L3[lid] = _on_line_of_sight(cameras[views[0]], case.views[views[0]].landmarks[lid],
                                    [L3[r] for r in refs])
        estimated.add(lid)
        warnings.append(
            f"landmark {lid} was not reconstructed in 3D (clicked in "
            f"{photo_label(case, views[0])} only); for the curves it is placed on its line "
            f"of sight at the depth of {', '.join(refs)}")
    return L3, estimated, warnings
