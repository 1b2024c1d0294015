"""The served app's downloads: the meshes, landmarks, measurements and session file of
the open simulation, as (file name, content) for ``send_file_download``.

The bytes come from :mod:`naseview.app.export` and :mod:`naseview.texture.mesh_files`
(meshes in mm, GLB in metres); the
textured and solid meshes, which need the photo texture, are
:func:`naseview.app.face_look.look_export`'s.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any

from naseview.app.export import (
    landmarks_csv,
    landmarks_json,
    measurements_csv,
    measurements_json,
)
from naseview.editing.controller import EditController
from naseview.texture.mesh_files import mesh_file


def export_file(ctl: EditController, kind: str, fmt: str, case_id: str,
                app_state: Callable[[], dict[str, Any]], part: str = "face",
                state: str = "simulated") -> tuple[str, bytes]:
    """(file name, content) of an export of the simulation ``ctl`` edits: ``kind``
    ``"mesh"`` (``fmt`` a mesh type; ``part`` face or nose, ``state`` simulated or
    original), ``"landmarks"`` / ``"measurements"`` (``fmt`` json or csv) or
    ``"session"`` (the editor's state with ``app_state()``, what the app adds).

    Raises:
        ValueError: an unknown ``kind``.
    """
    name = case_id.replace("/", "_") or "case"
    if kind == "mesh":
        base = ctl.baseline
        V = ctl.simulation.V if state == "simulated" else base.V
        data = mesh_file(V, base.F, fmt, base.nose_ids if part == "nose" else None)
        return f"{name}-{part}-{state}.{fmt}", data
    if kind == "landmarks":
        base = ctl.baseline
        lms = ctl.simulation.drawn(ctl.landmarks)   # on the simulated surface
        data = (landmarks_json(lms, base.landmarks, case_id) if fmt == "json"
                else landmarks_csv(lms, base.landmarks))
        return f"{name}-landmarks.{fmt}", data
    if kind == "measurements":
        before, after = ctl.baseline.measurements, ctl.simulation.measurements
        data = (measurements_json(before, after, case_id) if fmt == "json"
                else measurements_csv(before, after))
        return f"{name}-measurements.{fmt}", data
    if kind == "session":
        ctl.wait_idle(10.0)
        obj = ctl.session_json(app_state())
        data = json.dumps(obj, separators=(",", ":"), allow_nan=False).encode("utf-8")
        return f"{name}-session.json", data
    raise ValueError(f"unknown export {kind!r}")


__all__ = ["export_file"]
