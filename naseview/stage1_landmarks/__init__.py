"""Stage 1 (paper §3.2): 3D landmarks and cameras by bundle adjustment of the clicks."""

from naseview.stage1_landmarks.solve import SfmParams, SfmResult, bundle_adjust

__all__ = ["SfmParams", "SfmResult", "bundle_adjust"]
