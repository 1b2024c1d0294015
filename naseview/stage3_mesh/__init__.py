"""Stage 3 (paper §3.4): morphable-model base face refined by ARAP and cotangent smoothing."""

from naseview.stage3_mesh.solve import NoseDeformer, RefineParams, refine

__all__ = ["NoseDeformer", "RefineParams", "refine"]
