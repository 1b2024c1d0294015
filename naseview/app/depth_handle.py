"""The depth handle: move the selected landmark in and out of the skin from any view.

A sphere drag moves a landmark in the screen plane, so depth can change only from a
profile view. The depth handle is a one-axis arrow (viser transform controls, translation
only) at the selected landmark, along the skin's outward normal there: dragging it moves
the landmark by ``t * n`` where ``t`` is the arrow's travel (mm) and ``n`` the unit normal
of the reconstruction at the landmark. It uses the controller's drag protocol
(``begin_drag`` / ``drag_to`` / ``end_drag``), so a depth move is one undo entry,
symmetric mode mirrors it and the drag limit applies, exactly as for a sphere drag.

Example
-------
    handle = DepthHandle(client.scene, controller)
    handle.select("prn", shown_position, normal)   # the arrow appears at the tip
"""

from __future__ import annotations

import logging
import threading

import numpy as np
import viser

from naseview.editing.controller import EditController

log = logging.getLogger(__name__)

HANDLE_SCALE_MM = 9.0
"""Length of the arrow in the scene (mm)."""


def normal_quaternion(n: np.ndarray) -> np.ndarray:
    """(4,) unit quaternion (w, x, y, z) turning +z onto the unit vector ``n`` (3,)."""
    z = np.array([0.0, 0.0, 1.0])
    n = np.asarray(n, np.float64) / max(float(np.linalg.norm(n)), 1e-12)
    c = float(np.dot(z, n))
    if c < -1.0 + 1e-9:                      # opposite: half turn about x
        return np.array([0.0, 1.0, 0.0, 0.0])
    axis = np.cross(z, n)
    q = np.array([1.0 + c, *axis])
    return q / np.linalg.norm(q)


class DepthHandle:
    """One tab's depth arrow, shown at the selected landmark.

    Args:
        scene: the tab's scene (viser ``SceneApi`` of a client, or the server's).
        controller: the editor the moves go to.
    """

    def __init__(self, scene: viser.SceneApi, controller: EditController) -> None:
        self.scene = scene
        self.ctl = controller
        self.landmark: str | None = None
        self._normal = np.array([0.0, 0.0, 1.0])
        self._origin = np.zeros(3)          # handle position when the move started
        self._start = np.zeros(3)           # landmark (controller) position then
        self._dragging = False
        self._lock = threading.Lock()
        self._handle: viser.TransformControlsHandle | None = None

    def select(self, landmark: str | None, position: np.ndarray | None = None,
               normal: np.ndarray | None = None) -> None:
        """Show the arrow at ``position`` (3,) mm along ``normal`` (3,) for
        ``landmark``; ``None`` hides it."""
        with self._lock:
            if self._dragging:
                return
            if landmark is None or position is None or normal is None:
                self.landmark = None
                if self._handle is not None:
                    self._handle.visible = False
                return
            self.landmark = landmark
            self._normal = np.asarray(normal, np.float64) / max(
                float(np.linalg.norm(normal)), 1e-12)
            q = normal_quaternion(self._normal)
            p = np.asarray(position, np.float64)
            if self._handle is None:
                self._handle = self._add(q, p)
            else:
                self._handle.wxyz = q
                self._handle.position = p
                self._handle.visible = True

    def follow(self, position: np.ndarray) -> None:
        """Keep the arrow on the landmark after it moved (undo, a solve), unless the
        surgeon is moving the arrow right now."""
        with self._lock:
            if self._handle is not None and not self._dragging and self.landmark:
                self._handle.position = np.asarray(position, np.float64)

    def _add(self, q: np.ndarray, p: np.ndarray) -> viser.TransformControlsHandle:
        h = self.scene.add_transform_controls(
            "/landmarks/depth_handle", scale=HANDLE_SCALE_MM, line_width=3.0,
            active_axes=(False, False, True), disable_rotations=True, disable_sliders=True,
            depth_test=False, wxyz=q, position=p)
        h.on_update(self._on_update)
        return h

    def _on_update(self, event: viser.TransformControlsEvent) -> None:
        """The arrow's drag phases (only a browser's move acts; never solves here)."""
        if event.client is None:
            return
        if event.phase == "start":
            self._begin()
        elif event.phase == "end":
            self._move()
            self._end()
        else:
            self._move()

    def _begin(self) -> None:
        lid, h = self.landmark, self._handle
        if lid is None or h is None:
            return
        with self._lock:
            self._dragging = True
            self._origin = np.asarray(h.position, np.float64).copy()
            self._start = self.ctl.landmarks[lid]
        self.ctl.begin_drag(lid)

    def _move(self) -> None:
        """Record the latest request only (the controller's worker solves)."""
        lid, h = self.landmark, self._handle
        if lid is None or h is None or not self._dragging:
            return
        t = float(np.dot(np.asarray(h.position, np.float64) - self._origin, self._normal))
        self.ctl.drag_to(lid, self._start + t * self._normal)

    def _end(self) -> None:
        if not self._dragging:
            return
        with self._lock:
            self._dragging = False
        self.ctl.end_drag()

    def remove(self) -> None:
        """Delete the arrow."""
        with self._lock:
            h, self._handle = self._handle, None
        if h is not None:
            try:
                h.remove()
            except Exception:  # the tab went away
                log.debug("naseview: depth handle of a closed tab", exc_info=True)
