"""naseview: 3D nose reconstruction from four photos and 21 landmarks, no neural network.

The pipeline (:mod:`naseview.pipeline`) follows Toan, Tuan, Thinh, "Non-Neural 3D Nasal
Reconstruction: A Sparse Landmark Algorithmic Approach for Medical Applications", CMES 2025:

1. stage 1 — landmarks (paper §3.2), :mod:`naseview.stage1_landmarks`: 3D landmarks and
   cameras by bundle adjustment of the clicks;
2. stage 2 — curves (paper §3.3), :mod:`naseview.stage2_curves`: the six boundary curves
   and the 76 ad-landmarks;
3. stage 3 — mesh (paper §3.4), :mod:`naseview.stage3_mesh`: morphable-model base face,
   ARAP and cotangent smoothing of the nose.

File formats and the SPEC frame are described in ``docs/formats.md``.
"""

__version__ = "0.1.0"
