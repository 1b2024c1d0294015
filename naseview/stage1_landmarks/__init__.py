"""Stage 1 (paper §3.2): 3D landmarks and cameras by bundle adjustment of the clicks.

Modules, in the order :func:`bundle_adjust` (``solve``) uses them:

- ``params``: :class:`SfmParams`, every tunable, checked once.
- ``validate``: one-line errors for clicks eq. 1 cannot use and fits that failed.
- ``template``: the generic nose that starts the cameras.
- ``initial``: rig prior, 2D similarity fit, DLT triangulation, resection, rig hypotheses.
- ``rotations``, ``problem``: residuals and analytic Jacobian of eq. 1, the solve.
- ``suspects``: leave-one-out suspect clicks.
- ``frame``: the SPEC §4 frame, gauge and millimetre scale.
- ``uncertainty``: 3D covariance of the landmarks.
- ``symmetry``, ``single_view``: landmarks clicked in one photo only.
- ``result``: :class:`SfmResult` and :class:`SuspectClick`.
"""

from naseview.stage1_landmarks.frame import anatomical_frame
from naseview.stage1_landmarks.params import SfmParams
from naseview.stage1_landmarks.result import SfmResult, SuspectClick
from naseview.stage1_landmarks.solve import bundle_adjust

__all__ = ["SfmParams", "SfmResult", "SuspectClick", "anatomical_frame", "bundle_adjust"]
