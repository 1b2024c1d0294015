"""Stage 3 (paper §3.4): morphable-model base face refined by ARAP and cotangent smoothing.

One module per step, in the order :func:`refine` (``solve.py``) runs them:

- ``params.py`` - :class:`RefineParams`, every tunable, validated;
- ``fit.py`` - the morphable-model fit to the landmarks, the base face (eq. 18);
- ``curve_fractions.py`` - where a sub-landmark sits on a mesh curve (arc-length fraction);
- ``correspondences.py`` - ad-landmarks to base-mesh vertices, the handles;
- ``warp.py`` - the smooth bi-Laplacian warp of the base towards them (naseview's addition);
- ``profile_band.py`` - the glabella-to-upper-lip band the profile photos show (issue 23);
- ``band_warp.py`` - the face around that band bent onto the profile silhouettes;
- ``silhouette.py``, ``sightline.py`` - the photos' occluding contours as handles, and the
  landmarks seen in one photo placed on their lines of sight;
- ``deform.py`` - :class:`NoseDeformer`: ARAP (eq. 19-20) and cotangent smoothing (eq. 21),
  precomputed once, solved many times;
- ``result.py`` - :class:`RefineResult`;
- ``solve.py`` - :func:`refine`, the stage.

The surface error and the ablation that measure it live in the test bed
(:mod:`naseview.testbed.surface`).
"""

from naseview.geometry.region import grow_by_distance, submesh
from naseview.stage3_mesh.correspondences import Correspondences, correspondences
from naseview.stage3_mesh.deform import DeformReport, NoseDeformer, deform_region
from naseview.stage3_mesh.fit import BaseFit, fit_face_model
from naseview.stage3_mesh.params import RefineParams
from naseview.stage3_mesh.result import RefineResult
from naseview.stage3_mesh.solve import refine
from naseview.stage3_mesh.warp import smooth_warp

__all__ = [
    "BaseFit", "Correspondences", "DeformReport", "NoseDeformer", "RefineParams",
    "RefineResult", "correspondences", "deform_region", "fit_face_model", "grow_by_distance",
    "refine", "smooth_warp", "submesh",
]
