"""What a consultation report shows, and the sentence every report carries."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from naseview.texture.bake import FaceTexture

DISCLAIMER = "A simulation is not a promised outcome."
"""The sentence every report carries (also in the de-identified version)."""

DISCLAIMER_DETAIL = (
    "The images after the simulation show a geometric deformation of a 3D model built "
    "from four photos; healing, skin thickness and cartilage behave differently in every "
    "patient. Measurements are estimates from photos, typically within about 1 mm.")


@dataclass
class ReportData:
    """What a report shows (SPEC frame, mm).

    Attributes:
        case_id: anonymised id.
        V_before: (N, 3) face mesh of the reconstruction.
        F: (M, 3) triangles.
        nose_ids: (K,) vertices of the nose region.
        measurements_before: name -> value of the reconstruction.
        V_after: (N, 3) simulated mesh, or ``None`` (no simulation: "before" only).
        measurements_after: name -> value after the simulation, or ``None``.
        photos: view -> (H, W, 3) uint8 BGR photo (may be empty).
        notes: free text (left out of the de-identified version).
        credit: face model credit line.
        date: date shown in the header (default today).
        texture: the patient's own skin baked from the photos for ``V_before``'s mesh
            (:func:`naseview.texture.bake.bake_texture`), or ``None`` (plain skin colour).
            Never used in the de-identified version.
    """

    case_id: str
    V_before: np.ndarray
    F: np.ndarray
    nose_ids: np.ndarray
    measurements_before: dict[str, float]
    V_after: np.ndarray | None = None
    measurements_after: dict[str, float] | None = None
    photos: dict[str, np.ndarray] = field(default_factory=dict)
    notes: str = ""
    credit: str = ""
    date: str = ""
    texture: FaceTexture | None = None
