"""The patient's own face for the app: the texture baked once per reconstruction, shared by
every tab.

:func:`face_look` returns the :class:`FaceLook` of the app's current reconstruction: the
:class:`~naseview.texture.bake.FaceTexture` baked from the case's photos with the stage-1
cameras (:func:`naseview.texture.bake.bake_texture`; None without photos, e.g. a session
whose case folder is gone) and the :class:`~naseview.app.face_glb.FaceGlb` parts every
tab's scene sends. It is computed once per (baseline, moving region) and cached on the app,
so the first caller pays for the bake — the app bakes it on the job thread right after
the editor is up and the tabs show the face in plain skin (the bake takes longer than the
rest of the install, issue 27 item 6: ``face_look(app, bake=False)`` never waits for it),
then shows it in every tab — and every tab that connects later reuses it.
"""

from __future__ import annotations

import logging
import threading
import time
import weakref
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from naseview.app.face_glb import FaceGlb
from naseview.camera import Camera
from naseview.case import Case
from naseview.editing.baseline import Baseline
from naseview.editing.controller import EditController
from naseview.errors import NaseviewError
from naseview.texture.bake import BakeParams, FaceTexture, case_photos, skin_texture
from naseview.texture.mesh_files import mesh_file, textured_obj_zip

log = logging.getLogger(__name__)

TEXTURE_SIZE = BakeParams().size
"""Texels per side of the app's face texture (the bake's default, which
``naseview reconstruct --export glb`` bakes too)."""


class LookSource(Protocol):
    """What :func:`face_look` reads of the app
    (:class:`naseview.app.naseview_app.NaseviewApp`)."""

    @property
    def controller(self) -> EditController | None:
        """The patient's editor (None before a case is open)."""

    @property
    def case(self) -> Case | None:
        """The case directory with the photos, when available."""

    @property
    def cameras(self) -> dict[str, Camera]:
        """view -> stage-1 camera of the open reconstruction."""

    @property
    def moving(self) -> np.ndarray:
        """(K,) ids of the vertices an edit moves (empty: the nose)."""


@dataclass(frozen=True)
class FaceLook:
    """How one reconstruction is shown.

    Attributes:
        baseline: the reconstruction it was made for.
        texture: the baked texture, None without photos.
        parts: the rest / nose GLBs of the face.
        photos: view -> (H, W, 3) uint8 BGR photo of the case (empty without photos).
        bake_s: seconds the bake took (0 without photos).
    """

    baseline: Baseline
    texture: FaceTexture | None
    parts: FaceGlb
    photos: Mapping[str, np.ndarray]
    bake_s: float


def make_look(baseline: Baseline, region: np.ndarray, cameras: Mapping[str, Camera],
              photos: Mapping[str, np.ndarray], size: int = TEXTURE_SIZE) -> FaceLook:
    """Bake the texture of ``baseline`` (when photos with cameras exist) and build its
    GLB parts for the moving ``region``. A photo the bake refuses (wrong size) leaves the
    face untextured and is logged, never fatal."""
    t0 = time.perf_counter()
    usable = {v: p for v, p in photos.items() if v in cameras}
    tex = skin_texture(baseline.V, baseline.F, cameras, usable, BakeParams(size=size))
    took = time.perf_counter() - t0 if tex is not None else 0.0
    parts = FaceGlb(baseline.V, baseline.F, region, texture=tex)
    return FaceLook(baseline, tex, parts, dict(usable), took)


_CACHE: weakref.WeakKeyDictionary[object, FaceLook] = weakref.WeakKeyDictionary()
_LOCK = threading.Lock()


def face_look(app: LookSource, bake: bool = True) -> FaceLook | None:
    """The look of ``app``'s open reconstruction (baked on first use, then cached on the
    app); None while nothing is open. With ``bake`` False only an already baked look is
    returned (None while it is missing or being baked: the caller shows plain skin and
    never waits for the bake)."""
    ctl = app.controller
    if ctl is None:
        return None
    base = ctl.baseline
    region = np.asarray(app.moving if len(app.moving) else base.nose_ids, np.int64)
    if not _LOCK.acquire(blocking=bake):   # one bake at a time; the others wait, reuse it
        return None
    try:
        hit = _CACHE.get(app)
        if hit is not None and hit.baseline is base \
                and np.array_equal(hit.parts.region, region):
            return hit
        if not bake:
            return None
        look = make_look(base, region, app.cameras, case_photos(app.case, app.cameras))
        _CACHE[app] = look
        return look
    finally:
        _LOCK.release()


def set_face_look(app: LookSource, look: FaceLook) -> None:
    """Use ``look`` for ``app`` (made with :func:`make_look` for its baseline and moving
    region, e.g. from photos a script rendered); tabs built afterwards show it."""
    with _LOCK:
        _CACHE[app] = look


def prepare_face_look(app: LookSource) -> None:
    """Bake the texture of ``app``'s reconstruction now (call on the job thread, after the
    controller is installed and before the tabs' scenes are rebuilt)."""
    face_look(app)




def look_export(app: LookSource, kind: str, fmt: str, part: str = "face",
                state: str = "simulated", case_id: str | None = None) -> tuple[str, bytes]:
    """(file name, content) of an export that needs the look: ``kind`` ``"textured"``
    (``fmt`` ``glb``: the texture embedded, metres; ``obj``: a ZIP of OBJ + MTL + PNG, mm)
    or ``"solid"`` (a watertight solid for printing, ``fmt`` a mesh type); ``part`` face
    or nose, ``state`` simulated or original.

    Raises:
        NaseviewError: nothing open, or a textured export without photos.
    """
    ctl = app.controller
    if ctl is None:
        raise NaseviewError("nothing to export yet: the reconstruction is not ready")
    base = ctl.baseline
    V = ctl.simulation.V if state == "simulated" else base.V
    ids = base.nose_ids if part == "nose" else None
    name = str(case_id or getattr(app, "case_id", None) or "case").replace("/", "_")
    stem = f"{name}-{part}-{state}"
    if kind == "solid":
        return f"{stem}-solid.{fmt}", mesh_file(V, base.F, fmt, ids, watertight=True)
    look = face_look(app)
    if look is None or look.texture is None:
        raise NaseviewError("no photo texture: this reconstruction has no photos (open its "
                            "case folder); use the plain mesh exports")
    if fmt == "obj":
        return f"{stem}-textured.zip", textured_obj_zip(V, base.F, look.texture, ids, stem)
    return f"{stem}-textured.{fmt}", mesh_file(V, base.F, fmt, ids, texture=look.texture)


__all__ = ["FaceLook", "LookSource", "TEXTURE_SIZE", "face_look",
           "look_export", "make_look", "prepare_face_look", "set_face_look"]
