"""The 3D scene of one browser tab: face, nose, landmarks, curves, ad-landmarks, cameras.

Each tab has its own :class:`FaceScene` in its client scope (:mod:`naseview.app.scope`),
subscribed to the patient's one :class:`EditController`: an edit in any tab shows in every
tab, while what each tab shows (toggles, before / after, the patient-mode blend) is its
own. Everything lives in the SPEC frame (mm, +y up). The face is split in two meshes so that a
live update sends only the nose: ``/face/rest`` (static) and ``/face/nose`` (every triangle
touching the nose region; its outer ring never moves, so there is no crack). The
landmarks are two batched sphere meshes: the editable ones (inside the nose region) take
``on_drag``; the others are drawn grey and fixed. Clicking or dragging a sphere selects it
and shows the depth arrow (:mod:`naseview.app.depth_handle`) to move it in or out from any
view. Spheres are drawn where the landmarks sit on the shown surface: the requested
position plus what the plan's manoeuvres do there (:meth:`Simulation.landmark_offset`).

Pure helpers (:mod:`naseview.app.scene_geometry`) carry the geometry;
:class:`FaceScene` owns the viser handles. The colour map (:mod:`naseview.app.colormap`)
shows the signed displacement of the simulation (stage 3's ARAP edit, paper §3.4) along
the surface normal.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Iterable, Mapping, Sequence

import cv2
import numpy as np
import viser

from naseview.app.colormap import (
    diverging_colors,
    nice_limit,
    signed_displacement,
    vertex_color_glb,
)
from naseview.app.depth_handle import DepthHandle
from naseview.app.face_glb import FaceGlb
from naseview.app.ghost import ghost_segments
from naseview.app.landmark_names import display_name
from naseview.app.scene_geometry import (
    blend,
    camera_pose,
    curve_segments,
    label_layout,
    outline_smoother,
    region_outline,
    split_region,
)
from naseview.app.scope import Scope
from naseview.camera import Camera
from naseview.case import Case
from naseview.editing.baseline import Landmarks, Simulation
from naseview.editing.controller import EditController
from naseview.errors import NaseviewError
from naseview.geometry.mesh import vertex_normals
from naseview.landmarks import CURVE_NAMES

log = logging.getLogger(__name__)

SKIN = (226, 192, 168)
NOSE = SKIN  # the nose keeps the skin colour; the region is highlighted by its outline
OUTLINE = (205, 110, 60)
ORIGINAL = (60, 110, 220)
LANDMARK_EDITABLE = (214, 38, 40)
LANDMARK_FIXED = (140, 140, 140)
LANDMARK_ACTIVE = (255, 214, 0)
CURVE = (20, 160, 60)
AD_LANDMARK = (40, 110, 220)
SPHERE_RADIUS_MM = 1.1
LABEL_LIFT_MM = 2.2
"""Height of a landmark label above its sphere (mm)."""

CONSTRUCTION = "/construction"
"""Parent node of the construction overlays (curves, ad-landmarks, nose outline, cameras,
fixed landmarks): hidden by default, shown by the panel's "Show construction"."""


UNDERLAY_INSET_MM = 0.05
"""How far below the textured nose its plain underlay lies (mm, along the normals)."""


class NoseNode:
    """The live nose GLB (:class:`~naseview.app.face_glb.FaceGlb`) as a node whose
    ``vertices`` (k, 3) mm (the face's nose-part vertices, ``FaceScene.nose_ids``) can be
    assigned: each assignment re-packs positions and normals and replaces the GLB.

    A browser takes a while to decode a replaced GLB (its texture JPEG; 2 s and more with
    software WebGL) and draws nothing there meanwhile: the nose was a hole after every drag
    (issue 27). Under the GLB lies a plain mesh of the same nose in the texture's median
    skin colour, :data:`UNDERLAY_INSET_MM` inside it, updated first on every assignment
    (only its vertices travel): hidden by the textured nose once that is drawn, it shows
    the new shape while the GLB loads."""

    def __init__(self, scene: viser.SceneApi, name: str, parts: FaceGlb,
                 base_V: np.ndarray, ids: np.ndarray) -> None:
        self._scene = scene
        self._name = name
        self._parts = parts
        self._base = np.asarray(base_V, np.float64)
        self._ids = ids
        self._vertices = self._base[ids].copy()
        self._visible = True
        P, N = self._geometry()
        self.underlay = scene.add_mesh_simple(
            f"{name}_underlay", (P - UNDERLAY_INSET_MM * N).astype(np.float32),
            parts.nose_faces, color=parts.nose_rgb, flat_shading=False, cast_shadow=False,
            receive_shadow=False)
        self.handle: viser.GlbHandle = self._send(P, N)

    def _geometry(self) -> tuple[np.ndarray, np.ndarray]:
        """The nose part's positions and normals for the current vertices."""
        V = self._base.copy()
        V[self._ids] = self._vertices
        return self._parts.nose_geometry(V)

    def _send(self, P: np.ndarray, N: np.ndarray) -> viser.GlbHandle:
        """Replace the GLB with the nose part at positions ``P``, normals ``N``."""
        return self._scene.add_glb(self._name, self._parts.pack_nose(P, N),
                                   visible=self._visible, cast_shadow=False,
                                   receive_shadow=False)

    @property
    def vertices(self) -> np.ndarray:
        """(k, 3) float32 vertices shown (mm), like a simple mesh handle's."""
        return self._vertices.astype(np.float32)

    @vertices.setter
    def vertices(self, V: np.ndarray) -> None:
        V = np.asarray(V, np.float64)
        if V.shape == self._vertices.shape and np.array_equal(V, self._vertices):
            return
        self._vertices = V.copy()
        P, N = self._geometry()                  # once for the underlay and the GLB
        self.underlay.vertices = (P - UNDERLAY_INSET_MM * N).astype(np.float32)
        self.handle = self._send(P, N)

    @property
    def visible(self) -> bool:
        return self._visible

    @visible.setter
    def visible(self, on: bool) -> None:
        self._visible = bool(on)
        self.handle.visible = self._visible
        self.underlay.visible = self._visible

    def remove(self) -> None:
        self.handle.remove()
        self.underlay.remove()


def _show(handles: Iterable[viser.SceneNodeHandle | None], visible: bool) -> None:
    """Set ``visible`` on every handle that exists."""
    for h in handles:
        if h is not None:
            h.visible = visible


def _icosphere(radius: float) -> tuple[np.ndarray, np.ndarray]:
    """(V, 3) vertices and (F, 3) faces of an icosphere (2 subdivisions) of ``radius``."""
    import trimesh  # lazy: see naseview.app.colormap.vertex_color_glb

    s = trimesh.creation.icosphere(subdivisions=2, radius=radius)
    return np.asarray(s.vertices), np.asarray(s.faces)


def photo_thumbnails(case: Case | None, cameras: Mapping[str, Camera], width: int = 320
                     ) -> dict[str, np.ndarray]:
    """view -> (h, ``width``, 3) uint8 RGB thumbnail of each reconstructed view's photo
    that ``case`` can load (for the camera frustums; none without a case)."""
    photos: dict[str, np.ndarray] = {}
    if case is None:
        return photos
    for v in cameras:
        try:
            image_bgr = case.load_image(v)
        except NaseviewError:
            continue
        h, w = image_bgr.shape[:2]
        s = width / float(w)
        small = cv2.resize(image_bgr, (width, max(1, int(round(h * s)))),
                           interpolation=cv2.INTER_AREA)
        photos[v] = small[:, :, ::-1].copy()
    return photos


class FaceScene:
    """Viser handles of one baseline, updated from an :class:`EditController`.

    Args:
        scope: where the nodes live: a ``viser.ClientHandle`` (one tab) or the
            ``viser.ViserServer`` (every tab).
        controller: the editor.
        editable: landmark ids that can be dragged (inside the deforming region).
        cameras: view -> camera of the reconstruction (frustums), may be empty.
        photos: view -> (H, W, 3) uint8 RGB thumbnail shown in the frustum.
        region: vertices the solver may move (default ``baseline.nose_ids``); the nose
            mesh is every triangle touching them.
        parts: the face's GLB parts (textured: :func:`naseview.app.face_look.face_look`);
            default untextured skin for ``region``.
    """

    def __init__(self, scope: Scope, controller: EditController,
                 editable: Sequence[str], cameras: Mapping[str, Camera] | None = None,
                 photos: Mapping[str, np.ndarray] | None = None,
                 region: np.ndarray | None = None, parts: FaceGlb | None = None) -> None:
        self.scope = scope
        self.scene = scope.scene
        self.ctl = controller
        base = controller.baseline
        self.base = base
        self.editable = [i for i in editable if i in base.landmarks]
        self.fixed = [i for i in base.landmarks if i not in self.editable]
        self._lock = threading.Lock()
        self.region = np.asarray(base.nose_ids if region is None else region, np.int64)
        self.nose_ids, self.nose_F, self.rest_ids, _ = split_region(
            base.F, self.region, len(base.V))
        self.normals = vertex_normals(base.V, base.F)
        self.show_colormap = False
        self.show_original = False
        self.show_overlay = False
        self.highlight = True
        self.blend = 1.0
        self.colormap_limit = 0.0
        self._last_colormap = 0.0
        self._active: dict[int, tuple[str, np.ndarray]] = {}

        self.scene.set_up_direction("+y")
        self.parts = parts if parts is not None and np.array_equal(parts.region, self.region) \
            else FaceGlb(base.V, base.F, self.region)
        self.construction = self.scene.add_frame(CONSTRUCTION, show_axes=False,
                                                 visible=False)
        self.rest, self.nose = self._add_face()
        self.original = self._add_original()
        self.colormap: viser.GlbHandle | None = None
        self.outline = self._add_outline()
        lms = controller.landmarks
        self.depth = DepthHandle(self.scene, controller)
        self._lm_vertex = {k: int(np.argmin(np.linalg.norm(base.V - p, axis=1)))
                           for k, p in base.landmarks.items() if k in self.editable}
        self.spheres, self.fixed_spheres = self._add_spheres(lms)
        self.labels = {
            i: self.scene.add_label(f"/labels/{i}", display_name(i),
                                    position=self._label_position(i, lms[i]),
                                    visible=False, font_screen_scale=1.25,
                                    anchor="bottom-center")
            for i in base.landmarks}
        self.show_labels = False
        self._active_label: str | None = None
        self.label_camera: Camera | None = None
        self.curves = self._add_curves()
        self.ad = self._add_ad_landmarks()
        self.frustums: dict[str, viser.CameraFrustumHandle] = {}
        self._camera_labels: list[viser.LabelHandle] = []
        self._add_cameras(cameras or {}, photos or {})
        controller.on_simulation.append(self.update)
        controller.on_landmarks.append(self.set_landmarks)

    def _add_face(self) -> tuple[viser.GlbHandle, NoseNode]:
        """The static rest of the face (eye and mouth openings capped) and the live nose,
        both from :class:`FaceGlb` (one skin, normals of the whole face: no seam)."""
        rest = self.scene.add_glb("/face/rest", self.parts.rest_glb(), cast_shadow=False,
                                  receive_shadow=False)
        nose = NoseNode(self.scene, "/face/nose", self.parts, self.base.V, self.nose_ids)
        return rest, nose

    def _add_original(self) -> viser.LineSegmentsHandle:
        """A ghost of the original nose: its contour lines (:mod:`naseview.app.ghost`),
        lifted 0.15 mm along the normals so they stay on top where nothing changed;
        hidden until asked for."""
        base = self.base
        inside = np.zeros(len(base.V), dtype=bool)
        inside[np.asarray(base.nose_ids, np.int64)] = True
        gF = np.asarray(base.F, np.int64)[inside[base.F].all(axis=1)]
        if len(gF) == 0:
            gF = np.asarray(base.F, np.int64)[inside[base.F].any(axis=1)]
        lifted = base.V + 0.15 * self.normals
        segs = ghost_segments(lifted, gF) if len(gF) else np.zeros((0, 2, 3))
        if not len(segs):
            segs = np.zeros((1, 2, 3))
        return self.scene.add_line_segments("/face/original", segs, ORIGINAL,
                                            thickness=1.6, thickness_units="screen",
                                            visible=False)

    def _add_outline(self) -> viser.LineSegmentsHandle | None:
        """The smoothed outline of the nose region (None when it has no border)."""
        base = self.base
        edges = region_outline(base.F, base.nose_ids, len(base.V))
        self._outline_ids, self._outline_S = outline_smoother(edges)
        self._outline_loc = np.searchsorted(self._outline_ids, edges)
        return self.scene.add_line_segments(
            f"{CONSTRUCTION}/nose_outline", self._outline_points(base.V), OUTLINE, thickness=2.0,
            thickness_units="screen") if len(edges) else None

    def _add_spheres(self, lms: Landmarks) -> tuple[viser.BatchedMeshHandle | None,
                                                    viser.BatchedMeshHandle | None]:
        """Red draggable spheres for the editable landmarks, grey ones for the fixed."""
        sv, sf = _icosphere(SPHERE_RADIUS_MM)
        unit = np.tile([1.0, 0.0, 0.0, 0.0], (1, 1))
        spheres = None
        if self.editable:
            spheres = self.scene.add_batched_meshes_simple(
                "/landmarks/editable", sv, sf,
                batched_wxyzs=np.repeat(unit, len(self.editable), axis=0),
                batched_positions=np.array([lms[i] for i in self.editable]),
                batched_colors=np.array([LANDMARK_EDITABLE] * len(self.editable),
                                        dtype=np.uint8),
                cast_shadow=False, receive_shadow=False)
            spheres.on_drag(self._on_drag)
            spheres.on_click(self._on_click)
        fixed = None
        if self.fixed:
            fixed = self.scene.add_batched_meshes_simple(
                f"{CONSTRUCTION}/fixed_landmarks", sv, sf,
                batched_wxyzs=np.repeat(unit, len(self.fixed), axis=0),
                batched_positions=np.array([lms[i] for i in self.fixed]),
                batched_colors=LANDMARK_FIXED, cast_shadow=False, receive_shadow=False)
        return spheres, fixed

    def _add_curves(self) -> dict[str, viser.LineSegmentsHandle]:
        """The SPEC §5 curves of the baseline (those with two points or more)."""
        out = {}
        for name in CURVE_NAMES:
            c = self.base.curves.get(name)
            if c is None or len(c) < 2:
                continue
            out[name] = self.scene.add_line_segments(
                f"{CONSTRUCTION}/curves/{name}", curve_segments(c, name.startswith("sill")), CURVE,
                thickness=2.5, thickness_units="screen")
        return out

    def _add_ad_landmarks(self) -> viser.PointCloudHandle | None:
        """The ad-landmarks as a point cloud (None when there are none)."""
        if not len(self.base.ad_landmarks):
            return None
        return self.scene.add_point_cloud(
            f"{CONSTRUCTION}/ad_landmarks", np.asarray(self.base.ad_landmarks), AD_LANDMARK,
            point_size=0.6, point_shape="circle", precision="float32",
            point_shading="flat")

    def _add_cameras(self, cameras: Mapping[str, Camera],
                     photos: Mapping[str, np.ndarray]) -> None:
        """A frustum with the photo thumbnail and a label per reconstructed camera."""
        for view, cam in cameras.items():
            wxyz, pos = camera_pose(cam)
            fov = 2.0 * np.arctan2(cam.height / 2.0, cam.K[1, 1])
            self.frustums[view] = self.scene.add_camera_frustum(
                f"{CONSTRUCTION}/cameras/{view}", fov=float(fov), aspect=cam.width / cam.height,
                scale=40.0, thickness=1.5, thickness_units="screen", color=(60, 60, 60),
                image=photos.get(view), format="jpeg", jpeg_quality=80, wxyz=wxyz,
                position=pos)
            self._camera_labels.append(self.scene.add_label(
                f"{CONSTRUCTION}/cameras/{view}/label", view, position=(0.0, 0.0, 0.0),
                font_screen_scale=0.8))

    # drag
    async def _on_drag(self, event: viser.SceneNodeDragEvent[viser.BatchedMeshHandle]
                       ) -> None:
        """Batched-sphere drag: record the latest request only (never solves here)."""
        idx = event.instance_index
        if idx is None or not (0 <= idx < len(self.editable)):
            return
        lid = self.editable[idx]
        end = np.asarray(event.end_position, dtype=np.float64)
        key = int(event.client_id)
        if event.phase == "start":
            centre = self.ctl.landmarks[lid]
            self._active[key] = (lid, centre - np.asarray(event.start_position, dtype=float))
            self.ctl.begin_drag(lid)
            self._highlight(lid)
            self._show_active_label(lid)
            self.select(lid)
            return
        active = self._active.get(key)
        if active is None or active[0] != lid:
            return
        self.ctl.drag_to(lid, end + active[1])
        if event.phase == "end":
            self._active.pop(key, None)
            self.ctl.end_drag()
            self._highlight(None)
            self._show_active_label(None)

    def _on_click(self, event: viser.SceneNodePointerEvent[viser.BatchedMeshHandle]
                  ) -> None:
        """A click on a sphere selects its landmark (the depth arrow appears there)."""
        idx = event.instance_index
        if idx is not None and 0 <= idx < len(self.editable):
            self.select(self.editable[idx])

    def select(self, lid: str | None) -> None:
        """Show the depth arrow at editable landmark ``lid`` (None: hide it)."""
        if lid is None or lid not in self._lm_vertex:
            self.depth.select(None)
            return
        p = self._shown(self.ctl.landmarks)[lid]
        self.depth.select(lid, p, self.normals[self._lm_vertex[lid]])

    def _shown(self, lms: Landmarks) -> Landmarks:
        """Where landmarks at ``lms`` (controller positions) are drawn: plus the
        manoeuvres' offset of each in the last published simulation."""
        return self.ctl.simulation.drawn(lms)

    def _highlight(self, lid: str | None) -> None:
        if self.spheres is None:
            return
        colors = np.array([LANDMARK_ACTIVE if i == lid else LANDMARK_EDITABLE
                           for i in self.editable], dtype=np.uint8)
        self.spheres.batched_colors = colors

    # labels
    def _label_position(self, lid: str, p: np.ndarray) -> np.ndarray:
        """(3,) label anchor of landmark ``lid`` at ``p`` (mm): above the sphere and pushed
        away from the nose's centre (left landmarks to the left, the tip forwards), so the
        labels around the tip do not pile up on each other."""
        nose = self.base.V[self.nose_ids] if len(self.nose_ids) else self.base.V
        c = nose.mean(axis=0)
        d = np.asarray(p, np.float64) - c
        d[1] = 0.0
        n = float(np.linalg.norm(d))
        out = d / n * 3.0 if n > 1e-6 else np.zeros(3)
        return np.asarray(p, np.float64) + out + np.array([0.0, LABEL_LIFT_MM, 0.0])

    def _label_wanted(self, lid: str) -> bool:
        """A label shows when the labels are on (the editable landmarks: the ones the
        surgeon moves) or while its landmark is dragged."""
        return lid == self._active_label or (self.show_labels and lid in self.editable)

    def _refresh_labels(self) -> None:
        lms = self._shown(self.ctl.landmarks)
        wanted = {i: self._label_position(i, lms[i]) for i in self.labels
                  if self._label_wanted(i)}
        placed: Mapping[str, np.ndarray | None] = wanted
        cam = self.label_camera
        if cam is not None and wanted:
            try:
                placed = label_layout(wanted, lms, {i: display_name(i) for i in wanted},
                                      self.shown_vertices(self.ctl.simulation),
                                      self.base.F, cam)
            except Exception:  # a label layout never breaks the scene
                log.debug("naseview: label layout failed", exc_info=True)
        for i, h in self.labels.items():
            p = placed.get(i)
            want = p is not None
            if p is not None:
                h.position = p
            if h.visible != want:
                h.visible = want

    def set_label_camera(self, camera: Camera | None) -> None:
        """The tab's current view (None: unknown): labels of landmarks it cannot see are
        hidden and overlapping ones spread (:func:`label_layout`)."""
        self.label_camera = camera
        if any(self._label_wanted(i) for i in self.labels):
            self._refresh_labels()

    def _show_active_label(self, lid: str | None) -> None:
        """The dragged landmark's label (``None``: the drag ended)."""
        self._active_label = lid
        self._refresh_labels()

    # updates
    def set_landmarks(self, lms: Landmarks) -> None:
        """Move the spheres and labels (cheap; called as soon as landmarks change)."""
        lms = self._shown(lms)
        if self.depth.landmark in lms:
            self.depth.follow(lms[self.depth.landmark])
        if self.spheres is not None:
            self.spheres.batched_positions = np.array([lms[i] for i in self.editable])
        if self.fixed_spheres is not None:
            self.fixed_spheres.batched_positions = np.array([lms[i] for i in self.fixed])
        for i, h in self.labels.items():
            if h.visible:
                h.position = self._label_position(i, lms[i])

    def shown_vertices(self, sim: Simulation) -> np.ndarray:
        """(N, 3) vertices shown for ``sim`` (mm): the simulation, or ``blend`` of the way
        from the reconstruction to it (patient mode's before / after slider)."""
        return sim.V if self.blend >= 1.0 else blend(self.base.V, sim.V, self.blend)

    def set_blend(self, t: float) -> None:
        """Show the face ``t`` (0..1) of the way from before to after, in this scope."""
        with self._lock:
            self.blend = float(np.clip(t, 0.0, 1.0))
            sim = self.ctl.simulation
            V = self.shown_vertices(sim)
            with self.scope.atomic():
                self.nose.vertices = V[self.nose_ids]

    def update(self, sim: Simulation) -> None:
        """Push a solved state: nose vertices, curves, ad-landmarks (and the colour map)."""
        with self._lock:
            V = self.shown_vertices(sim)
            with self.scope.atomic():
                if not self.show_original:
                    self.nose.vertices = V[self.nose_ids]
                for name, h in self.curves.items():
                    c = sim.curves.get(name)
                    if c is not None and len(c) >= 2:
                        h.points = curve_segments(c, name.startswith("sill"))
                if self.outline is not None and not self.show_original:
                    self.outline.points = self._outline_points(V)
                if self.ad is not None and len(sim.ad_landmarks) == len(self.base.ad_landmarks):
                    self.ad.points = np.asarray(sim.ad_landmarks)
                if self.show_colormap:
                    now = time.perf_counter()
                    final = self.ctl.dragging is None
                    if final or now - self._last_colormap > 0.25:
                        self._last_colormap = now
                        self._push_colormap(V)
                self.set_landmarks(self.ctl.landmarks)

    def _outline_points(self, V: np.ndarray) -> np.ndarray:
        """(E, 2, 3) smoothed outline segments of the nose region on the face ``V``."""
        P = self._outline_S @ V[self._outline_ids]
        return P[self._outline_loc]

    def _push_colormap(self, V: np.ndarray) -> None:
        ids = self.nose_ids
        d = signed_displacement(self.base.V[ids], V[ids], self.normals[ids])
        self.colormap_limit = nice_limit(float(np.abs(d).max()) if len(d) else 0.0)
        colors = diverging_colors(d, self.colormap_limit, NOSE if self.highlight else SKIN)
        self.colormap = self.scene.add_glb("/face/colormap",
                                           vertex_color_glb(V[ids], self.nose_F, colors),
                                           visible=self.show_colormap)

    def set_view(self, *, colormap: bool | None = None, original: bool | None = None,
                 overlay: bool | None = None) -> None:
        """Before/after toggles: colour map of the displacement, show the original
        (before) nose instead of the simulated one, translucent overlay of the original."""
        with self._lock:
            if colormap is not None:
                self.show_colormap = colormap
            if original is not None:
                self.show_original = original
            if overlay is not None:
                self.show_overlay = overlay
            V = self.base.V if self.show_original else self.shown_vertices(
                self.ctl.simulation)
            self.nose.vertices = V[self.nose_ids]
            if self.outline is not None:
                self.outline.points = self._outline_points(V)
            self.original.visible = self.show_overlay and not self.show_original
            if self.show_colormap:
                self._push_colormap(V)
            elif self.colormap is not None:
                self.colormap.visible = False
            self.nose.visible = not self.show_colormap

    def set_visible(self, *, labels: bool | None = None, curves: bool | None = None,
                    ad_landmarks: bool | None = None, cameras: bool | None = None,
                    landmarks: bool | None = None, highlight: bool | None = None,
                    construction: bool | None = None) -> None:
        """Show / hide groups of the scene. ``construction`` shows the construction
        overlays as a whole (:data:`CONSTRUCTION`); ``curves``, ``ad_landmarks``,
        ``cameras`` and ``highlight`` (the nose outline) choose among them; ``landmarks``
        is the draggable spheres (and the fixed ones, when construction is shown)."""
        if construction is not None:
            self.construction.visible = construction
        if labels is not None:
            self.show_labels = labels
            self._refresh_labels()
        if curves is not None:
            _show(self.curves.values(), curves)
        if ad_landmarks is not None:
            _show([self.ad], ad_landmarks)
        if cameras is not None:
            _show(self.frustums.values(), cameras)
        if landmarks is not None:
            _show([self.spheres, self.fixed_spheres], landmarks)
        if highlight is not None:
            self.highlight = highlight
            _show([self.outline], highlight)

    def remove(self) -> None:
        """Detach from the controller and delete every node."""
        if self.update in self.ctl.on_simulation:
            self.ctl.on_simulation.remove(self.update)
        if self.set_landmarks in self.ctl.on_landmarks:
            self.ctl.on_landmarks.remove(self.set_landmarks)
        self.depth.remove()
        handles: list[viser.SceneNodeHandle | None] = [
                   self.rest, self.nose.handle, self.outline, self.original,
                   self.colormap, self.spheres, self.fixed_spheres, self.ad,
                   *self.labels.values(), *self.curves.values(), *self._camera_labels,
                   *self.frustums.values(), self.construction]
        for h in handles:
            if h is not None:
                try:
                    h.remove()
                except Exception:  # already removed
                    pass
