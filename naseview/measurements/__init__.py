"""Clinical nasal measurements from the 3D landmarks, the curves and the refined mesh.

The 11 landmark distances of the paper's Table 1 (section 4; SPEC §6) and, beyond the
paper, the measurements a rhinoplasty surgeon cites: profile (nasal length and height,
nasofrontal angle, dorsal hump, radix, nasolabial angle), tip (rotation, projection by
Goode and by Crumley, columellar show), widths (nasal width, alar base, nasal index,
intercanthal width estimated from the face model) and symmetry (dorsal and tip deviation
from the facial midline, nostril areas). All inputs are in the SPEC frame (mm, origin g,
+x subject's left, +y up, +z anterior). One module per family:

- :mod:`.frame`: the facial midline plane and the lateral projection;
- :mod:`.section`: the ordered plane section of a mesh (the profile);
- :mod:`.profile`: profile and tip measurements;
- :mod:`.width`: distances, widths, intercanthal width;
- :mod:`.symmetry`: deviations and nostril symmetry;
- :mod:`.info`: :data:`MEASUREMENT_INFO` (definition, patient sentence, inputs, ranges,
  sources) and :func:`calliper_inputs`;
- :mod:`.uncertainty`: a measurement's sd from its landmarks' stated uncertainties
  (:func:`measurement_uncertainty`) and which are shown as estimates
  (:func:`estimated_measurements`, :data:`ESTIMATED_SD_MM`).

Definitions and references: ``docs/measurements.md``.

Example
-------
>>> m = clinical_measurements({"n": np.array([0.0, -15, -3]), "prn": np.array([0.0, -45, 25])})
>>> round(m["n-prn"], 2), round(m["nasal_length"], 2), MEASUREMENT_INFO["nasal_length"].unit
(41.04, 41.04, 'mm')
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from naseview.measurements.frame import (
    CleanLandmarks,
    MidlinePlane,
    angle_deg,
    clean_landmarks,
    midline_plane,
)
from naseview.measurements.info import (
    MEASUREMENT_INFO,
    MeasurementInfo,
    calliper_inputs,
    format_measurements,
)
from naseview.measurements.profile import (
    Profile,
    dorsal_hump_depth,
    facial_profile,
    profile_measurements,
)
from naseview.measurements.section import topology
from naseview.measurements.symmetry import deviation_measurements
from naseview.measurements.uncertainty import (
    ESTIMATED_SD_MM,
    Estimate,
    estimated_measurements,
    measurement_uncertainty,
)
from naseview.measurements.width import distance_key, distances, intercanthal

__all__ = [
    "ESTIMATED_SD_MM", "MEASUREMENT_INFO", "Estimate", "MeasurementInfo", "MidlinePlane",
    "Profile", "angle_deg", "calliper_inputs", "clinical_measurements", "distance_key",
    "dorsal_hump_depth", "estimated_measurements", "facial_profile", "format_measurements",
    "measurement_uncertainty", "midline_plane",
]


def clinical_measurements(landmarks: Mapping[str, np.ndarray],
                          curves: Mapping[str, np.ndarray] | None = None,
                          V: np.ndarray | None = None,
                          F: np.ndarray | None = None) -> dict[str, float]:
    """Every measurement of :data:`MEASUREMENT_INFO` whose inputs are present.

    The profile measurements use the cut of the mesh (V, F) by the facial midline plane
    when the mesh is given (else ``curves["mid"]``, else the landmarks); definitions in
    :mod:`.frame`, :mod:`.profile`, :mod:`.width` and :mod:`.symmetry`. A measurement
    whose landmarks, curves or mesh are missing, or whose geometry is degenerate (e.g.
    coincident landmarks), is omitted; this never raises for such input.

    Args:
        landmarks: id -> (3,) position, mm (any subset of the 21).
        curves: optional SPEC §5 curves, name -> (N, 3) mm.
        V, F: optional refined face (or nose) mesh, (n, 3) mm / (m, 3) int.
    Returns:
        name -> value (mm, degrees or a plain ratio), in :data:`MEASUREMENT_INFO` order.
    """
    if V is not None and F is not None:
        V = np.asarray(V, np.float64).reshape(-1, 3)
        F = np.asarray(F, np.int64).reshape(-1, 3)
        if len(V) == 0 or len(F) == 0 or not np.isfinite(V).all() \
                or F.min(initial=0) < 0 or F.max(initial=0) >= len(V):
            V = F = None
    else:
        V = F = None
    topo = None if V is None or F is None else topology(F)
    clean = clean_landmarks(landmarks)
    world = midline_plane(clean)
    # Everything below runs in the plane's own frame (lateral, up, anterior): a rotation
    # and a shift, so distances and angles are unchanged and the projections are slices.
    R = np.stack([world.normal, world.up, world.anterior])
    lms = CleanLandmarks({k: (p - world.origin) @ R.T for k, p in clean.items()})
    local_curves = None if curves is None else {
        k: (np.asarray(c, np.float64).reshape(-1, 3) - world.origin) @ R.T
        for k, c in curves.items()}
    V = None if V is None else (V - world.origin) @ R.T
    plane = MidlinePlane(np.zeros(3), np.eye(3)[0], np.eye(3)[1], np.eye(3)[2])
    with np.errstate(all="ignore"):
        out = distances(lms)
        prof = facial_profile(lms, plane, local_curves, V, topo)
        out.update(profile_measurements(lms, plane, prof, local_curves))
        out.update(intercanthal(lms, plane, V, topo, out.get("nasal_width")))
        out.update(deviation_measurements(lms, plane, local_curves, V, topo))
    return {k: float(out[k]) for k in MEASUREMENT_INFO
            if k in out and math.isfinite(out[k])}
