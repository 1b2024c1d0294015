"""naseview: 3D nose reconstruction from four photos and 21 landmarks, no neural network.

The pipeline follows Toan, Tuan, Thinh, "Non-Neural 3D Nasal Reconstruction: A Sparse
Landmark Algorithmic Approach for Medical Applications", CMES 2025:

1. :mod:`naseview.stage1_landmarks` — 3D landmarks and cameras by bundle adjustment (3.2).
2. :mod:`naseview.stage2_curves` — six boundary curves and the 76 ad-landmarks (section 3.3).
3. :mod:`naseview.stage3_mesh` — morphable-model base face, ARAP, cotangent smoothing (3.4).
"""

__version__ = "0.1.0"
