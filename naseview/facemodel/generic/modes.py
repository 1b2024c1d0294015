"""The generic face's modes: smooth localised deformation fields (design step 5).

The parametric face is ``W(theta) = mean + sum_k theta_k D_k(mean)`` with ``D_k`` a
smooth, localised deformation field per anatomical parameter (the tip sliding along the
dorsum, the alae moving out, a dorsal bump, ...), so every basis vector is exactly its
derivative ``D_k``, scaled so that a unit coefficient changes the parameter's defining
measurement (:func:`mode_measurements`) by about one population standard deviation
(:data:`MODE_SD_MM`). Nose modes vanish beyond the nose's creases; whole-face modes leave
the nose in place.

Example
-------
>>> from naseview.facemodel.generic import generic_face_model
>>> meas = mode_measurements(generic_face_model())                    # doctest: +SKIP
>>> round(meas["nose_length"](generic_face_model().mean))             # doctest: +SKIP
48
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from naseview.facemodel.generic.annotate import nostril_rim
from naseview.facemodel.generic.mesh import GenericMesh, generic_mesh
from naseview.facemodel.generic.nose import membership, underside_y
from naseview.facemodel.generic.nostrils import nostril_frame, nostril_rho
from naseview.facemodel.generic.shapes import gauss, smoothstep
from naseview.facemodel.model import FaceModel

NOSE_MODES: tuple[str, ...] = ("nose_length", "projection", "dorsal_hump", "tip_width",
                               "alar_width", "nostril_size")
"""Interpretable nose modes (localised to the nose, zero far from it)."""

FACE_MODES: tuple[str, ...] = ("face_width", "face_height", "brow_prominence")
"""Whole-face modes (they leave the external nose in place)."""

MODE_SD_MM: dict[str, float] = {
    "nose_length": 3.0,       # n-prn
    "projection": 2.5,        # prn ahead of ac (z)
    "dorsal_hump": 1.5,       # k above the n-prn line
    "tip_width": 1.5,         # lobule width in the bottom view (al'-al')
    "alar_width": 2.5,        # al-al
    "nostril_size": 1.0,      # nostril width (short axis)
    "face_width": 5.0,        # width of the face at the cheekbones
    "face_height": 5.0,       # sn to menton
    "brow_prominence": 1.5,   # g ahead of n (z)
}
"""Change (mm) of each mode's defining measurement per unit coefficient."""


def _nose_weight(mesh: GenericMesh) -> np.ndarray:
    """(N,) 1 on the external nose, 0 on the face beyond its creases, smooth in between."""
    m = membership(mesh.V_uncarved)
    return smoothstep((m + 2.5) / 6.5)


def _nose_fields(mesh: GenericMesh, P: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Raw (N, 3) fields of the nose modes but the nostrils: the tip sliding along the
    dorsum (radix and alar bases stay), projection forwards growing from the alar creases
    to the tip, a dorsal bump between k and r, the tip lobule spreading sideways, the alae
    and lower sidewalls moving out. ``P``: landmark positions on the mean."""
    V = mesh.V
    x, y, z = V[:, 0], V[:, 1], V[:, 2]
    w = _nose_weight(mesh)
    L = float(np.linalg.norm(P["prn"] - P["n"]))
    u = (P["prn"] - P["n"]) / L                         # dorsal direction, down-forward
    n_d = np.array([0.0, u[2], -u[1]])                   # normal to it, up-forward
    s = ((V - P["n"]) @ u) / L                           # 0 at n, 1 at prn
    fields: dict[str, np.ndarray] = {}
    ac_z = 0.5 * (P["ac_l"][2] + P["ac_r"][2])
    h = np.clip((z - ac_z) / (P["prn"][2] - ac_z), 0.0, 1.0)     # 0 at ac, 1 at prn
    fields["nose_length"] = (w * smoothstep(s) * smoothstep(1.25 * h))[:, None] * u
    fields["projection"] = (w * smoothstep(h))[:, None] * np.array([0.0, 0.0, 1.0])
    s0 = 0.5 * (((P["k"] - P["n"]) @ u) + ((P["r"] - P["n"]) @ u)) / L
    bump = gauss((s - s0) / 0.17) * gauss(x / 6.0)
    fields["dorsal_hump"] = (w * bump)[:, None] * n_d
    tip = P["prn"] + np.array([0.0, -2.0, -7.0])
    lob = gauss(np.linalg.norm((V - tip) / np.array([11.0, 7.0, 9.0]), axis=1))
    fields["tip_width"] = (w * lob * x)[:, None] * np.array([1.0, 0.0, 0.0])
    y_int = P["int_l"][1]
    low = smoothstep((y_int + 4.0 - y) / 8.0)
    lateral = smoothstep((np.abs(x) - 10.0) / 7.0) * np.sign(x)
    fields["alar_width"] = (w * low * lateral)[:, None] * np.array([1.0, 0.0, 0.0])
    return fields


def _nostril_field(mesh: GenericMesh) -> np.ndarray:
    """Raw (N, 3) field of ``nostril_size``: the nostrils grow in the plane of the nasal
    base, cups included."""
    V = mesh.V
    x = V[:, 0]
    f = np.zeros_like(V)
    X0 = mesh.V_uncarved
    dy = X0[:, 1] - underside_y(X0[:, 0], X0[:, 2])
    base = smoothstep((dy + 2.0) / 1.5) * (dy < 8.0)
    for side in (1.0, -1.0):
        rho = nostril_rho(X0, side)
        c, _, _, _ = nostril_frame(side)
        c3 = np.array([c[0], underside_y(c[0:1], c[1:2])[0], c[1]])
        wn = smoothstep((1.6 - rho) / 0.6) * base * (np.sign(x) == side)
        q = V - c3
        q[:, 1] *= 0.5                                   # mostly in the base plane
        f += wn[:, None] * q
    return f


def _face_fields(mesh: GenericMesh, P: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Raw (N, 3) fields of the whole-face modes; they leave the nose where it is."""
    V = mesh.V
    x, y = V[:, 0], V[:, 1]
    rest = 1.0 - smoothstep((membership(mesh.V_uncarved) + 4.0) / 3.0)
    fields: dict[str, np.ndarray] = {}
    fields["face_width"] = (x * smoothstep((np.abs(x) - 16.0) / 16.0))[:, None] \
        * np.array([1.0, 0.0, 0.0])
    y_sn = P["sn"][1]
    below = 0.5 * ((y_sn - 2.0 - y) + np.sqrt((y_sn - 2.0 - y) ** 2 + 9.0))
    fields["face_height"] = (rest * below)[:, None] * np.array([0.0, -1.0, 0.0])
    brow = gauss((y - P["g"][1]) / 9.0) * gauss(x / 30.0)
    fields["brow_prominence"] = (rest * brow)[:, None] * np.array([0.0, 0.0, 1.0])
    return fields


def _mode_fields(mesh: GenericMesh, lm: dict[str, int]) -> dict[str, np.ndarray]:
    """Raw (uncalibrated) displacement field (N, 3) of every mode on the mean mesh."""
    P = {k: mesh.V[i] for k, i in lm.items()}
    return {**_nose_fields(mesh, P), "nostril_size": _nostril_field(mesh),
            **_face_fields(mesh, P)}


Measurement = Callable[[np.ndarray], float]
"""A measurement (mm) as a function of the face's vertices (N, 3)."""


def _mode_measurements(mesh: GenericMesh, lm: dict[str, int]) -> dict[str, Measurement]:
    """Measurement (mm) defining each mode, as a function of the vertices (N, 3)."""
    V0 = mesh.V
    left = np.flatnonzero(mesh.nostril_side == 1)
    rim = nostril_rim(mesh.F, left)
    c, _, v, _ = nostril_frame(1.0)
    t = (V0[rim][:, [0, 2]] - c) @ v
    ends = (int(rim[np.argmin(t)]), int(rim[np.argmax(t)]))   # across the short axis
    mid = np.flatnonzero(np.abs(V0[:, 0]) < 1e-9)
    me = int(mid[np.argmin(V0[mid, 1])])
    side = (int(np.argmax(V0[:, 0])), int(np.argmin(V0[:, 0])))

    def dist(a: int, b: int) -> Measurement:
        return lambda V: float(np.linalg.norm(V[a] - V[b]))

    def hump(V: np.ndarray) -> float:
        n_, p_, k_ = V[lm["n"]], V[lm["prn"]], V[lm["k"]]
        u_ = (p_ - n_) / np.linalg.norm(p_ - n_)
        q = k_ - n_
        return float(np.linalg.norm(q - (q @ u_) * u_))

    return {
        "nose_length": dist(lm["n"], lm["prn"]),
        "projection": lambda V: float(V[lm["prn"], 2] - 0.5 * (V[lm["ac_l"], 2]
                                                                + V[lm["ac_r"], 2])),
        "dorsal_hump": hump,
        "tip_width": dist(lm["alp_l"], lm["alp_r"]),
        "alar_width": dist(lm["al_l"], lm["al_r"]),
        "nostril_size": dist(*ends),
        "face_width": dist(*side),
        "face_height": dist(lm["sn"], me),
        "brow_prominence": lambda V: float(V[lm["g"], 2] - V[lm["n"], 2]),
    }


def mode_measurements(model: FaceModel) -> dict[str, Measurement]:
    """Mode name -> function ``(V (N, 3)) -> mm`` of the measurement that mode changes.

    For a face ``V = model.shape(w)`` of the generic model, increasing ``w[k]`` by one
    changes measurement ``mode_names[k]`` by about ``MODE_SD_MM[mode_names[k]]``.
    """
    return _mode_measurements(generic_mesh(), dict(model.landmark_vertices))


def mode_basis(mesh: GenericMesh, lm: dict[str, int]) -> np.ndarray:
    """(K, N, 3) mode basis, each field scaled to one population SD of its measurement."""
    fields = _mode_fields(mesh, lm)
    meas = _mode_measurements(mesh, lm)
    out = []
    eps = 1e-3
    for name in NOSE_MODES + FACE_MODES:
        f = fields[name]
        rate = (meas[name](mesh.V + eps * f) - meas[name](mesh.V - eps * f)) / (2 * eps)
        out.append(f * (MODE_SD_MM[name] / rate))
    return np.stack(out)
