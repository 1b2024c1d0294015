"""A reconstruction's manoeuvre fields, precomputed once and applied many times.

:class:`ManoeuvrePlan` evaluates every field of :mod:`.dorsum`, :mod:`.tip`,
:mod:`.alar_base` and :mod:`.columella` on the rest shape (the reconstruction) once:
per translation its unit field ``U_m`` (displacement per mm), for the tip rotation its
weight, pivot and axis. Applying amounts is then a weighted sum over each field's support::

    D(amounts) = sum_m amount_m * U_m                     (translations: linear)
               + w * (R_theta (p - c) - (p - c))          (tip rotation by theta degrees)

The typed amounts are first mapped to the applied ones (:meth:`ManoeuvrePlan.applied`):
the hump reduction is capped where the dorsum is straight (the measured hump plus
:data:`HUMP_MARGIN_MM`), and the tip rotation is divided by the face's gain (the measured
tip rotation's change per degree of the field, measured once on the rest shape), so the
measurement each manoeuvre names (:data:`.info.MEASURES`) changes by the typed amount.

Every field is defined on the rest positions, so the fields add: ``D`` is exactly
commutative, undoable (amounts back to 0 give exactly 0) and the translations are linear
in their amounts. A landmark moves with the surface under it: it is attached to its
closest triangle (barycentric coordinates) on the rest shape and takes the barycentric
mean of the corners' displacements (:meth:`ManoeuvrePlan.landmark_offsets`), so it stays
on the displaced surface.

The fields fade to zero within the nose's own size; the fields of :data:`NOSE_ONLY` are
cut to the nose region (a lip that turns back under a long columella can come within a
field's reach: the columella set-back must not move the lip); the alar base and radix
fields fade into the cheek and the glabella, which the model's nose region may not reach:
:attr:`ManoeuvrePlan.region_ids` (the nose region plus those fade bands) are the vertices
that can move.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import igl
import numpy as np

from naseview.editing.manoeuvres.alar_base import alar_base_field
from naseview.editing.manoeuvres.columella import columella_setback_field
from naseview.editing.manoeuvres.dorsum import (
    dorsal_profile,
    hump_reduction_field,
    radix_augmentation_field,
)
from naseview.editing.manoeuvres.frame import NasalFrame, nasal_frame
from naseview.editing.manoeuvres.info import MANOEUVRES, check_amounts
from naseview.editing.manoeuvres.tip import (
    rotation_matrix,
    tip_narrowing_field,
    tip_projection_field,
    tip_rotation_pivot,
    tip_rotation_weight,
)
from naseview.measurements import clinical_measurements

NEEDS: dict[str, tuple[str, ...]] = {
    "hump_reduction": ("n", "prn"),
    "radix_augmentation": ("n", "prn"),
    "tip_projection": ("n", "prn"),
    "tip_rotation": ("n", "prn", "ac_l", "ac_r"),
    "tip_narrowing": ("n", "prn", "md_l", "md_r"),
    "alar_base_narrowing": ("n", "prn", "al_l", "ac_l", "al_r", "ac_r"),
    "columella_setback": ("n", "prn", "c", "sn"),
}
"""The landmarks each manoeuvre needs."""

NOSE_ONLY: frozenset[str] = frozenset({"hump_reduction", "tip_projection", "tip_narrowing",
                                      "columella_setback"})
"""Manoeuvres that move the nose region's vertices only."""

HUMP_MARGIN_MM = 0.25
"""A hump reduction is applied up to the measured hump plus this (the field leaves a
little of the measured hump in the supratip at exactly the hump depth)."""

SUPRATIP = 0.15
"""A measured hump whose highest point lies closer than this fraction of n-prn above prn
(about 7 mm) is the supratip (the lobule's convexity), not a dorsal hump: lowering it
there sharpens the tip (the dihedral angles at prn grow by 10-15 deg per mm on the demo
and james), and the plan says so."""

ROTATION_PROBE_DEG = 10.0
"""Angle (degrees) of the raw rotation field at which the tip rotation's gain is measured."""

ROTATION_GAIN = (0.7, 2.0)
"""Bounds of the measured tip rotation's change per degree of the raw field (a
columella held at the lip tilts more than the lobule turns: about 1.4 on the generic
face, 0.9 on the ICT base)."""

SUPPORT_EPS = 1e-12
"""Weights at or below this are outside a field's support."""


class ManoeuvrePlan:
    """The manoeuvre fields of one reconstruction (module docstring).

    Args:
        V: (N, 3) rest vertices (the reconstruction), mm. F: (M, 3) int triangles.
        nose_ids: (K,) vertices of the nose region.
        landmarks: id -> (3,) rest positions, mm.
        curves: SPEC §5 curves; ``"mid"`` (on the surface) joins the mesh's midline
            section as the dorsal profile of the hump reduction.

    Attributes:
        available: the manoeuvres this reconstruction supports (their landmarks present),
            in :data:`MANOEUVRES` order.
        region_ids: (R,) sorted vertices any manoeuvre can move (the nose region plus the
            fade bands into the cheek, lip and glabella).
        frame: the :class:`NasalFrame`, or None without n and prn.
    """

    def __init__(self, V: np.ndarray, F: np.ndarray, nose_ids: np.ndarray,
                 landmarks: Mapping[str, np.ndarray],
                 curves: Mapping[str, np.ndarray] | None = None) -> None:
        self.V = np.asarray(V, np.float64)
        self.F = np.asarray(F, np.int64)
        self.nose_ids = np.asarray(nose_ids, np.int64)
        self._lm_ids = [k for k, p in landmarks.items()
                        if np.all(np.isfinite(np.asarray(p, np.float64)))]
        self._lm = np.array([np.asarray(landmarks[k], np.float64).reshape(3)
                             for k in self._lm_ids]).reshape(-1, 3)
        self.frame: NasalFrame | None = nasal_frame(landmarks)
        fr = self.frame
        self.available: tuple[str, ...] = () if fr is None else tuple(
            m for m in MANOEUVRES if fr.has(*NEEDS[m]))
        self._fields: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        self._rotation: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = None
        P = self.V
        mid = None if curves is None else curves.get("mid")
        mid = None if mid is None else np.asarray(mid, np.float64).reshape(-1, 3)
        builders: dict[str, Callable[[NasalFrame, np.ndarray], np.ndarray]] = {
            "hump_reduction": lambda f, X: hump_reduction_field(f, X, self.V, self.F, mid),
            "radix_augmentation": radix_augmentation_field,
            "tip_projection": tip_projection_field,
            "tip_narrowing": tip_narrowing_field,
            "alar_base_narrowing": alar_base_field,
            "columella_setback": columella_setback_field,
        }
        support = [self.nose_ids]
        for m in self.available:
            assert fr is not None
            if m == "tip_rotation":
                w = tip_rotation_weight(fr, P)
                pivot, axis = tip_rotation_pivot(fr)
                idx = np.flatnonzero(w > SUPPORT_EPS)
                self._rotation = (idx, w[idx], self.V[idx] - pivot, axis)
            else:
                U = builders[m](fr, P)
                idx = np.flatnonzero(np.abs(U).max(axis=1) > SUPPORT_EPS)
                if m in NOSE_ONLY:
                    idx = np.intersect1d(idx, self.nose_ids)
                self._fields[m] = (idx, U[idx])
            support.append(idx)
        self.region_ids: np.ndarray = np.unique(np.concatenate(support)).astype(np.int64)
        self._attach_landmarks()
        self.hump_depth: float | None = None
        self.hump_above_tip: float | None = None
        self.supratip_hump = False
        self.rotation_gain = 1.0
        self._calibrate(landmarks, mid)

    def _calibrate(self, landmarks: Mapping[str, np.ndarray],
                   mid: np.ndarray | None = None) -> None:
        """:attr:`hump_depth` (the rest mesh's measured dorsal hump, mm),
        :attr:`hump_above_tip` (how far the dorsal profile's highest point lies above
        prn along n-prn, mm), :attr:`supratip_hump` (that is closer than
        :data:`SUPRATIP` of n-prn: the hump measured is the supratip) and
        :attr:`rotation_gain` (the measured tip rotation's change per degree of the raw
        rotation field, the secant over :data:`ROTATION_PROBE_DEG`, clamped to
        :data:`ROTATION_GAIN`; 1 when it cannot be measured)."""
        lms = {k: np.asarray(landmarks[k], np.float64) for k in self._lm_ids}
        m0 = clinical_measurements(lms, None, self.V, self.F)
        h = m0.get("dorsal_hump_depth")
        self.hump_depth = None if h is None else max(0.0, float(h))
        if self.frame is not None and "hump_reduction" in self.available:
            H, h_max = dorsal_profile(self.V, self.F, self.frame, mid)
            grid = np.linspace(0.0, 1.0, 201)
            if h_max > 0.0:
                peak = float(grid[int(np.argmax(H(grid)))])
                self.hump_above_tip = (1.0 - peak) * self.frame.length
        self.supratip_hump = self.hump_above_tip is not None and self.frame is not None \
            and self.hump_above_tip < SUPRATIP * self.frame.length
        if self._rotation is None or "tip_rotation" not in m0:
            return
        amounts = {"tip_rotation": ROTATION_PROBE_DEG}
        D = self._raw_displacement(amounts)
        off = self._landmark_offsets(D)
        m1 = clinical_measurements({k: lms[k] + off[k] for k in lms}, None, self.V + D,
                                   self.F)
        if "tip_rotation" in m1:
            g = (m1["tip_rotation"] - m0["tip_rotation"]) / ROTATION_PROBE_DEG
            self.rotation_gain = float(np.clip(g, *ROTATION_GAIN))

    def applied(self, amounts: Mapping[str, float]) -> dict[str, float]:
        """The amounts the fields are applied with for the typed ``amounts`` (checked,
        non-zero, :data:`MANOEUVRES` order): the hump reduction capped at
        :attr:`hump_depth` + :data:`HUMP_MARGIN_MM` (the dorsum ends straight; more
        would crease it into a saddle) and the tip rotation divided by
        :attr:`rotation_gain` (so that the measured tip rotation changes by the typed
        angle)."""
        out = dict(_ordered(amounts))
        if "hump_reduction" in out and self.hump_depth is not None:
            out["hump_reduction"] = min(out["hump_reduction"],
                                        self.hump_depth + HUMP_MARGIN_MM)
        if "tip_rotation" in out:
            out["tip_rotation"] = out["tip_rotation"] / self.rotation_gain
        return {k: v for k, v in out.items() if v != 0.0}

    def _attach_landmarks(self) -> None:
        """Each landmark's closest triangle corners (K, 3) and barycentric weights (K, 3)."""
        if len(self._lm) == 0 or len(self.F) == 0:
            self._lm_corners = np.zeros((len(self._lm), 3), np.int64)
            self._lm_bary = np.zeros((len(self._lm), 3))
            return
        P = np.ascontiguousarray(self._lm)
        V = np.ascontiguousarray(self.V)
        F = np.ascontiguousarray(self.F)
        _, fid, C = igl.point_mesh_squared_distance(P, V, F)
        fid = np.asarray(fid, np.int64).ravel()
        corners = F[fid]
        C = np.ascontiguousarray(np.asarray(C, np.float64).reshape(-1, 3))
        A, B, Cc = (np.ascontiguousarray(V[corners[:, k]]) for k in range(3))
        self._lm_corners = corners
        self._lm_bary = np.asarray(igl.barycentric_coordinates(C, A, B, Cc), np.float64)

    def displacement(self, amounts: Mapping[str, float]) -> np.ndarray:
        """(N, 3) mm displacement of the vertices for ``amounts`` (name -> mm / degrees,
        :func:`check_amounts`); zero rows outside :attr:`region_ids`, exactly zero for an
        empty mapping; manoeuvres not in :attr:`available` are skipped.

        Raises:
            NaseviewError: an unknown manoeuvre or an amount outside its range.
        """
        return self._raw_displacement(self.applied(amounts))

    def _raw_displacement(self, applied: Mapping[str, float]) -> np.ndarray:
        """(N, 3) displacement of the fields at the ``applied`` amounts (no cap, no gain)."""
        D = np.zeros_like(self.V)
        for m, x in applied.items():
            if m in self._fields:
                idx, U = self._fields[m]
                D[idx] += x * U
            elif m == "tip_rotation" and self._rotation is not None:
                idx, w, rel, axis = self._rotation
                D[idx] += w[:, None] * (rel @ (rotation_matrix(axis, x) - np.eye(3)).T)
        return D

    def landmark_offsets(self, amounts: Mapping[str, float]) -> dict[str, np.ndarray]:
        """Landmark id -> (3,) mm displacement by ``amounts``: the barycentric mean of the
        displacements of its closest rest triangle's corners (so a landmark on the
        surface stays on the displaced surface; one on a vertex moves with it exactly).

        Raises:
            NaseviewError: an unknown manoeuvre or an amount outside its range.
        """
        return self._landmark_offsets(self.displacement(amounts))

    def _landmark_offsets(self, D: np.ndarray) -> dict[str, np.ndarray]:
        """Landmark id -> (3,) displacement for the vertex displacement D (N, 3)."""
        off = np.einsum("kc,kcd->kd", self._lm_bary, D[self._lm_corners])
        return {k: off[i].copy() for i, k in enumerate(self._lm_ids)}


def _ordered(amounts: Mapping[str, float]) -> list[tuple[str, float]]:
    """The checked non-zero amounts in :data:`MANOEUVRES` order (so that the sum is the
    same, bit for bit, whatever the mapping's order)."""
    got = check_amounts(dict(amounts), "manoeuvres")
    return [(m, got[m]) for m in MANOEUVRES if m in got]
