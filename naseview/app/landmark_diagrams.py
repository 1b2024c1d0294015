"""Small pictures of where a landmark is, for the "new patient" page.

The face model (:mod:`naseview.facemodel`) is rendered (:func:`naseview.render.render_mesh`)
from the direction of each photo, its eye and mouth holes closed
(:func:`naseview.geometry.closing.cap_holes`); the landmarks asked for in that photo (SPEC §1) are
drawn as grey dots and the one to click as a red dot with a ring.
"""

from __future__ import annotations

import logging
import threading

import cv2
import numpy as np

from naseview.app.landmark_names import display_name
from naseview.camera import orbit_camera
from naseview.facemodel import FaceModel, load_face_model
from naseview.geometry.closing import cap_holes
from naseview.intake.click_order import CLICK_ORDER, PHOTO_ORDER
from naseview.render import render_mesh

log = logging.getLogger(__name__)

DIAGRAM_DIRECTIONS: dict[str, tuple[float, float, float]] = {
    "front": (0.0, 0.0, 1.0), "left": (1.0, 0.0, 0.12), "right": (-1.0, 0.0, 0.12),
    "bottom": (0.0, -0.8, 0.6), "oblique_left": (0.7, 0.0, 0.7),
    "oblique_right": (-0.7, 0.0, 0.7),
}
"""Direction from the nose to the diagram camera per photo (SPEC frame)."""

_Base = tuple[np.ndarray, dict[str, np.ndarray]]
"""A photo's rendered face (BGR) and the pixel (2,) of each landmark asked for in it."""


def _int_xy(p: np.ndarray) -> tuple[int, int]:
    return int(round(p[0])), int(round(p[1]))


class LandmarkDiagrams:
    """Small pictures of where a landmark is: the face model rendered from the photo's
    direction, the other landmarks of that photo as grey dots, the asked one as a red
    dot with a ring. Rendered once per photo, drawn once per landmark, then cached.

    Args:
        model: a :class:`~naseview.facemodel.FaceModel` or a name for
            ``load_face_model`` (``None``: ICT if installed, else the generic model).
        size: picture size (px).
    """

    def __init__(self, model: FaceModel | str | None = None, size: int = 200) -> None:
        self._model_arg = model
        self.size = size
        self._lock = threading.Lock()
        self._model: FaceModel | None = None
        self._failed = False
        self._base: dict[str, _Base] = {}
        self._cache: dict[tuple[str, str], np.ndarray] = {}

    def _load(self) -> FaceModel | None:
        """The face model, loaded once (None when none loads: no diagrams)."""
        if self._model is None and not self._failed:
            try:
                m = self._model_arg
                self._model = m if isinstance(m, FaceModel) else load_face_model(m)
            except Exception as e:  # no model: the page works without diagrams
                log.warning("naseview: landmark diagrams unavailable: %s", e)
                self._failed = True
        return self._model

    @staticmethod
    def _points(model: FaceModel) -> dict[str, np.ndarray]:
        """(3,) position of every landmark on the mean face, the ``add`` helpers halfway
        along the bottom curve between ``alp`` and ``prn``."""
        V = model.mean
        pts = {k: V[i] for k, i in model.landmark_vertices.items()}
        path = np.asarray(model.curve_vertices.get("bottom", []), dtype=np.int64)
        for side in ("l", "r"):
            a, b = model.landmark_vertices.get(f"alp_{side}"), model.landmark_vertices["prn"]
            ia, ib = np.flatnonzero(path == a), np.flatnonzero(path == b)
            if ia.size and ib.size:
                seg = path[min(ia[0], ib[0]):max(ia[0], ib[0]) + 1]
                pts[f"add_{side}"] = V[seg[len(seg) // 2]]
            elif f"alp_{side}" in pts:
                pts[f"add_{side}"] = 0.5 * (pts[f"alp_{side}"] + pts["prn"])
        return pts

    def _render(self, view: str) -> _Base | None:
        """The face seen from ``view``'s direction, framing its landmarks (cached)."""
        if view in self._base:
            return self._base[view]
        model = self._load()
        if model is None:
            return None
        pts = self._points(model)
        P = np.array([pts[i] for i in CLICK_ORDER[view] if i in pts])
        centre = 0.5 * (P.min(axis=0) + P.max(axis=0))
        cam = orbit_camera(centre, DIAGRAM_DIRECTIONS[view], 800.0,
                           1.35 * float(np.ptp(P, axis=0).max()), self.size)
        V, F = cap_holes(model.mean, model.faces)
        C = np.tile(np.array([150, 178, 222], np.uint8), (len(V), 1))
        nostrils = np.asarray(model.nostril_vertices, dtype=np.int64)
        C[nostrils] = (40, 40, 50)
        img = render_mesh(V, F, cam, vertex_colors=C, supersample=2,
                          background=(245, 245, 245)).image
        uv = {i: cam.project(pts[i])[0] for i in CLICK_ORDER[view] if i in pts}
        self._base[view] = (img, uv)
        return self._base[view]

    def _draw(self, base: _Base, landmark: str) -> np.ndarray:
        """(size, size, 3) uint8 RGB: grey dots for the others, a ringed red dot and the
        paper name for ``landmark``."""
        img, uv = base
        out = img.copy()
        for i, p in uv.items():
            if i != landmark:
                cv2.circle(out, _int_xy(p), 2, (120, 120, 120), -1, cv2.LINE_AA)
        if landmark in uv:
            q = _int_xy(uv[landmark])
            cv2.circle(out, q, 11, (255, 255, 255), 3, cv2.LINE_AA)
            cv2.circle(out, q, 11, (30, 30, 220), 1, cv2.LINE_AA)
            cv2.circle(out, q, 4, (30, 30, 220), -1, cv2.LINE_AA)
        label = display_name(landmark)
        cv2.putText(out, label, (6, self.size - 8), cv2.FONT_HERSHEY_SIMPLEX, 0.6,
                    (30, 30, 220), 2, cv2.LINE_AA)
        return np.ascontiguousarray(out[:, :, ::-1])

    def get(self, view: str, landmark: str) -> np.ndarray | None:
        """(size, size, 3) uint8 RGB picture, or ``None`` when no face model loads."""
        with self._lock:
            key = (view, landmark)
            if key in self._cache:
                return self._cache[key]
            base = self._render(view)
            if base is None:
                return None
            rgb = self._draw(base, landmark)
            self._cache[key] = rgb
            return rgb

    def warm(self) -> None:
        """Render every photo direction (call from a background thread)."""
        for v in PHOTO_ORDER:
            with self._lock:
                self._render(v)
