"""What stage 1 (paper §3.2) hands to stages 2 and 3: landmarks, cameras, their quality.

:class:`SfmResult` is in the SPEC §4 frame (millimetres, origin ``g``, +x the subject's
left, +y up, +z anterior); :class:`SuspectClick` is one click whose reprojection residual
(eq. 1) is far above the rest.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from naseview.camera import Camera

SuspectJson = dict[str, str | float | bool | list[str]]
"""JSON form of a :class:`SuspectClick` (``reconstruction.json``, ``extra.suspect_clicks``)."""


@dataclass(frozen=True)
class SuspectClick:
    """A click whose reprojection residual is far above the rest.

    Attributes:
        landmark, view: the click.
        residual_px: its distance (px) from the reprojection of the adjusted landmark.
        ignored: the click was left out of the final adjustment (the landmark's other
            photos agree with each other and not with it).
        other_views: for a landmark clicked in two photos only, the other photo: the two
            clicks disagree and either may be wrong.
    """

    landmark: str
    view: str
    residual_px: float
    ignored: bool = False
    other_views: tuple[str, ...] = ()

    def message(self) -> str:
        """One line for the user: which click to check, and whether it was left out."""
        if self.other_views:
            others = " and ".join(repr(v) for v in self.other_views)
            return (f"landmark {self.landmark!r}: the clicks in photos {self.view!r} and "
                    f"{others} disagree ({self.residual_px:.1f} px) and none can be shown "
                    "wrong; all kept, down-weighted; check both")
        action = "it was left out; check it" if self.ignored else "check it"
        return (f"click {self.landmark!r} in photo {self.view!r} is {self.residual_px:.1f} px "
                f"from where the other photos put it; {action}")

    def to_json(self) -> SuspectJson:
        """``{"landmark", "view", "residual_px" (px, 3 decimals), "ignored"[, "other_views"]}``."""
        out: SuspectJson = {"landmark": self.landmark, "view": self.view,
                            "residual_px": round(float(self.residual_px), 3),
                            "ignored": self.ignored}
        if self.other_views:
            out["other_views"] = list(self.other_views)
        return out


@dataclass
class SfmResult:
    """Stage-1 result in the SPEC frame (mm, origin g).

    Attributes:
        landmarks: id -> (3,) position (mm) of every landmark that could be placed, in
            the order of :data:`naseview.landmarks.LANDMARK_IDS`.
        cameras: view -> :class:`~naseview.camera.Camera` in the same frame.
        residuals_px: view -> id -> reprojection residual (px) of each click.
        uncertainty_mm: id -> 3D standard uncertainty (mm, root of the covariance trace),
            relative to the frame the adjusted landmarks define: 0 for an adjusted ``g``
            (the origin); for a ``g`` clicked in one photo, its placement uncertainty.
        covariance_mm2: id -> (3, 3) covariance (mm^2).
        reprojection_rmse_px: RMS reprojection error (px) over the adjusted clicks.
        suspect_clicks: clicks with a residual far above the rest, largest first.
        warnings: one-line messages for the user.
        one_photo: ids clicked in one photo only and placed on their viewing ray -> how:
            ``"symmetry"`` (mirror image of the partner), ``"midline"`` (midsagittal
            plane) or ``"template"`` (depth of the generic nose; weak).
        left_out: ids that were clicked but could not be placed.
        sigma_px: click noise (px) used for the uncertainty (estimate, floored).
        hypothesis: the rig hypothesis that won, e.g. ``"yaw 90, bottom 50"``.
        converged: the least-squares solver reported convergence.
        n_evaluations: residual evaluations of the final solve.
    """

    landmarks: dict[str, np.ndarray]
    cameras: dict[str, Camera]
    residuals_px: dict[str, dict[str, float]]
    uncertainty_mm: dict[str, float]
    covariance_mm2: dict[str, np.ndarray]
    reprojection_rmse_px: float
    suspect_clicks: list[SuspectClick] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    one_photo: dict[str, str] = field(default_factory=dict)
    left_out: tuple[str, ...] = ()
    sigma_px: float = 0.0
    hypothesis: str = ""
    converged: bool = True
    n_evaluations: int = 0
