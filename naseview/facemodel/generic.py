"""The built-in generic face: a linear face model made entirely by naseview's own code.

Used when the ICT model is not installed, for the bundled demo case, and in benchmarks as a
base face whose mesh has nothing in common with the ICT ground truth.

How the face is made
--------------------
1. **Shape.** The whole face is a height field ``z = S(x, y)`` (mm). The face without the
   nose (:func:`face_height`) is a sum of smooth terms: a head ellipse, a midline profile
   (forehead, glabella, lips, chin), brow ridges, eye sockets with eyeballs, lids and
   corneas, cheeks, nasolabial folds, lips with philtrum, Cupid's bow and mouth line, the
   labiomental fold. The external nose (:func:`nose_height`) is a dorsal ridge (profile,
   sidewall slope and roundness varying from radix to tip), the tip lobule and the two
   alar lobules (soft-rimmed ellipsoid caps) joined by polynomial smooth maxima, and cut
   from below by the nasal base (a plane rising forwards, higher beside the columella).
   Small blend radii make the alar creases and grooves, larger ones the nasofacial and
   supratip transitions (:func:`surface_height`).
2. **Mesh.** A graded, mirror-symmetric lattice (about 1 mm edges on the nose, 2 mm on
   eyes, lips and around the nose, 3.5 mm elsewhere) over an egg-shaped face outline in a
   plane whose normal ``d`` points forwards and 25 degrees down; each vertex is where the
   ray along ``d`` through its plane point meets the surface (unique, found by bisection),
   so the nose underside is sampled like the dorsum. Delaunay in the plane, then edge flips
   to the surface-Delaunay triangulation (no long thin triangles on steep sides).
3. **Nostrils.** Inside each nostril ellipse on the nasal base the vertices move up into
   the nose onto a half-ellipsoid cup (arc-length uniform): a real concave opening with a
   sharp rim. ``nostril_vertices`` are the cups and a thin ring of base around them.
4. **Annotations.** The 21 landmarks are found on the mean surface from their definitions
   (:func:`find_landmarks`); the curves come from
   :func:`naseview.facemodel.meshcurves.curve_paths`; the nose region is where the nose
   stands out of the face (:func:`nose_region`).
5. **Modes.** The parametric face is ``W(theta) = mean + sum_k theta_k D_k(mean)`` with
   ``D_k`` a smooth, localised deformation field per anatomical parameter (the tip sliding
   along the dorsum, the alae moving out, a dorsal bump, ...), so every basis vector is
   exactly its derivative ``D_k``, scaled so that a unit coefficient changes the
   parameter's defining measurement (:func:`mode_measurements`) by about one population
   standard deviation (:data:`MODE_SD_MM`). Nose modes vanish beyond the nose's creases;
   whole-face modes leave the nose in place; no triangle flips within +-2 SD.

Frame: SPEC axes (+x subject's left, +y up, +z anterior), millimetres; the origin is the
nasion of the design (not ``g``).

Example
-------
>>> from naseview.facemodel.generic import generic_face_model
>>> fm = generic_face_model()                          # doctest: +SKIP
>>> fm.mode_names[:3]                                  # doctest: +SKIP
('nose_length', 'projection', 'dorsal_hump')
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.spatial import ConvexHull, Delaunay, cKDTree

from naseview.facemodel import FaceModel
from naseview.landmarks import LANDMARK_IDS

CREDIT = "built-in generic face (naseview)"

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

TILT_DEG = 25.0
"""Angle between the meshing direction ``d`` and the +z axis (``d`` points down-forward)."""

_TILT = np.deg2rad(TILT_DEG)
E1 = np.array([1.0, 0.0, 0.0])
E2 = np.array([0.0, np.cos(_TILT), np.sin(_TILT)])
D = np.array([0.0, -np.sin(_TILT), np.cos(_TILT)])

LATTICE_MM: tuple[tuple[float, float], ...] = ((0.7, 0.62), (1.4, 1.24), (2.8, 2.48))
"""Column spacing along x and row spacing along ``e2`` of the three nested lattices in the
meshing plane: nose; eyes, lips and the nose's surroundings; elsewhere. The plane
foreshortens the dorsum and the nose underside about twice and the sidewalls are steep in
x, so 3D edges on the nose come out near 1 mm."""


# --------------------------------------------------------------------------------------
# small smooth building blocks
# --------------------------------------------------------------------------------------

def _smin(a: np.ndarray, b: np.ndarray, k: float) -> np.ndarray:
    """Polynomial smooth minimum (union of signed distances) with blend radius ``k`` mm."""
    h = np.maximum(k - np.abs(a - b), 0.0) / k
    return np.minimum(a, b) - 0.25 * k * h * h


def _smax(a: np.ndarray, b: np.ndarray, k: float) -> np.ndarray:
    """Polynomial smooth maximum (intersection) with blend radius ``k`` mm."""
    return -_smin(-a, -b, k)


def _smoothstep(t: np.ndarray) -> np.ndarray:
    """C1 step: 0 for t <= 0, 1 for t >= 1."""
    t = np.clip(t, 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def _gauss(u: np.ndarray) -> np.ndarray:
    return np.exp(-u * u)


class _Profile:
    """Natural cubic spline through knots (t, value), continued linearly outside them."""

    def __init__(self, knots: list[tuple[float, float]]) -> None:
        k = np.asarray(knots, dtype=np.float64)
        k = k[np.argsort(k[:, 0])]
        self._spl = CubicSpline(k[:, 0], k[:, 1], bc_type="natural")
        self._lo, self._hi = float(k[0, 0]), float(k[-1, 0])
        self._d_lo = float(self._spl(self._lo, 1))
        self._d_hi = float(self._spl(self._hi, 1))

    def __call__(self, t: np.ndarray, nu: int = 0) -> np.ndarray:
        t = np.asarray(t, dtype=np.float64)
        tc = np.clip(t, self._lo, self._hi)
        if nu == 1:
            return np.where(t < self._lo, self._d_lo,
                            np.where(t > self._hi, self._d_hi, self._spl(tc, 1)))
        v = self._spl(tc)
        return v + np.where(t < self._lo, (t - self._lo) * self._d_lo, 0.0) \
            + np.where(t > self._hi, (t - self._hi) * self._d_hi, 0.0)


# --------------------------------------------------------------------------------------
# the face without the nose: z = F(x, y)
# --------------------------------------------------------------------------------------

_Z0 = _Profile([(75, -30.0), (62, -15.0), (45, -6.0), (30, -1.2), (20, 1.0), (12, 1.8),
               (5, 1.0), (0, 0.0), (-10, -1.5), (-25, -1.5), (-40, -0.5), (-55, 0.5),
               (-70, 0.5), (-85, -0.5), (-100, -2.0), (-112, -5.0), (-120, -11.0),
               (-130, -28.0)])
"""Midline depth of the head surface (mm) before the midline protrusions."""

_HALF_W = _Profile([(75, 67.0), (40, 74.0), (0, 77.5), (-30, 79.0), (-60, 75.0),
                   (-90, 62.0), (-110, 52.0), (-130, 42.0)])
"""Half width of the transverse head ellipse (mm)."""

_PROTRUSION = _Profile([(0, 0.0), (-20, 0.0), (-32, 2.0), (-42, 7.5), (-50, 13.2),
                       (-56, 13.8), (-63, 13.5), (-71, 11.5), (-79, 12.5), (-90, 7.0),
                       (-100, 10.5), (-108, 11.0), (-116, 8.0), (-125, 1.0),
                       (-135, -2.0)])
"""Height (mm) of the midline protrusion of the jaws (lips, chin) above the head ellipse."""

_PROTRUSION_W = _Profile([(0, 24.0), (-30, 20.0), (-45, 17.5), (-60, 20.0), (-80, 20.0),
                         (-100, 17.0), (-120, 17.0)])
"""Width (mm) of that protrusion."""

HEAD_DEPTH_MM = 95.0


def _fissure(x: np.ndarray, y: np.ndarray, side: float) -> tuple[np.ndarray, np.ndarray,
                                                                   np.ndarray]:
    """Palpebral fissure of one eye: indicator in [0, 1], upper and lower lid margins (y)."""
    cx, cy = 31.0 * side, -8.0
    t = np.clip((x - cx) * side / 15.0, -1.0, 1.0)
    # almond: the upper lid peaks medially of the centre, the lateral canthus is higher
    up = cy + 5.5 * np.cos(0.5 * np.pi * t) * (1.0 - 0.15 * t) + 0.9 * t
    lo = cy - 3.8 * np.cos(0.5 * np.pi * t) * (1.0 + 0.1 * t) + 0.9 * t
    inside_x = _smoothstep((15.0 - np.abs(x - cx)) / 1.5)
    ind = (_smoothstep((up - y) / 1.4 + 0.5) * _smoothstep((y - lo) / 1.4 + 0.5) * inside_x)
    return ind, up, lo


EYE_CENTERS_MM = np.array([[31.0, -8.0], [-31.0, -8.0]])
"""(x, y) of the cornea centres (left, right) in the model frame, mm."""


def eye_fissure(x: np.ndarray, y: np.ndarray, side: float
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Palpebral fissure of the left (``side`` = +1) or right (-1) eye at points (x, y).

    Returns the open-eye indicator in [0, 1] (1 between the lids), and the heights y of
    the upper and lower lid margins above x (mm). Used to paint the eyes (synthetic
    photos) on this face.
    """
    return _fissure(np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64), side)


def face_height(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Depth ``z`` (mm) of the face without the nose at ``(x, y)`` (any equal shapes)."""
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    W = _HALF_W(y)
    u = np.clip(x / W, -0.995, 0.995)
    z = _Z0(y) - HEAD_DEPTH_MM * (1.0 - np.sqrt(1.0 - u * u))
    z = z + _PROTRUSION(y) * _gauss(x / _PROTRUSION_W(y))
    ax = np.abs(x)
    # forehead: frontal eminences; brow ridges and glabella
    z = z + 1.2 * _gauss((ax - 24.0) / 14.0) * _gauss((y - 42.0) / 12.0)
    z = z + 3.0 * _gauss((ax - 27.0) / 15.0) * _gauss((y - 15.0) / 6.5)
    z = z + 2.2 * _gauss(x / 11.0) * _gauss((y - 11.0) / 7.0)
    # cheeks (malar) and the infraorbital/tear-trough hollow
    z = z + 4.0 * _gauss((ax - 40.0) / 15.0) * _gauss((y + 30.0) / 13.0)
    z = z - 1.0 * _gauss((ax - 25.0) / 9.0) * _gauss((y + 20.0) / 3.5)
    # nasolabial fold: groove along a line from beside the ala to beside the mouth corner,
    # cheek fullness lateral to it
    p0 = np.array([19.0, -43.0])
    p1 = np.array([29.0, -74.0])
    seg = p1 - p0
    L2 = float(seg @ seg)
    s = np.clip(((ax - p0[0]) * seg[0] + (y - p0[1]) * seg[1]) / L2, 0.0, 1.0)
    dx = ax - (p0[0] + s * seg[0])
    dy = y - (p0[1] + s * seg[1])
    dist = np.sqrt(dx * dx + dy * dy)
    along = np.sin(np.pi * s)
    lateral = (dx * seg[1] - dy * seg[0]) / np.sqrt(L2)   # < 0 on the cheek side
    z = z - 1.3 * along * _gauss(dist / 2.2)
    z = z + 1.6 * along * _smoothstep(-lateral / 6.0) * _gauss(dist / 9.0)
    # eyes: socket, then eyeball + lids (smooth max), cornea, upper-lid crease
    for side in (1.0, -1.0):
        q2 = ((x - 31.0 * side) / 18.0) ** 2 + ((y + 4.0) / 13.5) ** 2
        z = z - 7.5 * np.exp(-(q2 ** 1.25))
        ind, up, lo = _fissure(x, y, side)
        r2 = (x - 31.0 * side) ** 2 + (y + 8.0) ** 2
        r = np.sqrt(r2)
        ball = np.where(r < 12.0, -27.5 + np.sqrt(np.maximum(12.0 ** 2 - r2, 0.0)),
                        -27.5 - 4.0 * (r - 12.0))
        lids = ball + 1.3 * (1.0 - ind)
        cornea = 1.6 * np.exp(-r2 / 25.0) * ind
        z = _smax(z, lids + cornea, 2.5)
        crease = _gauss((y - up - 5.5) / 1.1) * _smoothstep((16.0 - np.abs(x - 31.0 * side))
                                                             / 4.0)
        z = z - 0.9 * crease
        z = z - 0.5 * _gauss((y - lo + 2.2) / 1.3) * _smoothstep(
            (13.0 - np.abs(x - 31.0 * side)) / 4.0)
    # lips: mouth line, vermilions, philtrum
    y_st = -71.0 - 0.6 * (x / 25.0) ** 2
    taper = _smoothstep((26.0 - ax) / 6.0)
    z = z - 1.7 * _gauss((y - y_st) / 1.2) * taper
    # vermilions: steep at the border, rounding into the mouth line
    yu = y - y_st
    up = np.where(yu > 3.5, _gauss((yu - 3.5) / 2.2), _gauss((yu - 3.5) / 3.2))
    z = z + 3.4 * up * np.exp(-((x / 22.0) ** 4))
    lo = np.where(yu < -5.0, _gauss((yu + 5.0) / 3.0), _gauss((yu + 5.0) / 3.6))
    z = z + 4.2 * lo * np.exp(-((x / 20.0) ** 4))
    col = 3.4 + 0.16 * np.clip(-52.0 - y, 0.0, 12.0)        # philtral columns widen down
    in_phil = _smoothstep((-50.0 - y) / 5.0) * _smoothstep((y + 64.0) / 3.0)
    z = z + 0.55 * _gauss((ax - col) / 2.2) * in_phil
    z = z - 0.35 * _gauss(x / 2.5) * in_phil
    # vermilion border (white roll) with Cupid's bow
    y_vb = -63.2 + 0.9 * _gauss((ax - 5.0) / 2.5) - 0.5 * _gauss(x / 2.0) \
        - 5.0 * (np.clip(ax - 6.0, 0.0, None) / 20.0) ** 1.6
    z = z + 0.5 * _gauss((y - y_vb) / 0.7) * taper
    # modiolus hollows at the mouth corners
    z = z - 1.2 * _gauss((ax - 27.0) / 4.0) * _gauss((y + 71.0) / 4.0)
    return z


# --------------------------------------------------------------------------------------
# the external nose: also a height field, joined to the face by a smooth maximum
# --------------------------------------------------------------------------------------

_RIDGE_Z = _Profile([(14, -10.5), (6, -4.2), (0, 0.3), (-6, 4.7), (-12, 9.4), (-18, 13.9),
                    (-24, 18.3), (-29, 22.2), (-33, 25.3), (-38, 27.6), (-44, 28.2)])
"""Dorsal profile: midline height of the dorsal ridge (mm) at height y."""

_RIDGE_SLOPE = _Profile([(14, 0.8), (0, 0.95), (-10, 1.35), (-20, 1.65), (-30, 1.75),
                        (-38, 2.1), (-46, 2.4)])
"""Slope of the nasal sidewalls (dz/dx)."""

_RIDGE_ROUND = _Profile([(14, 10.0), (0, 8.0), (-10, 5.5), (-20, 4.6), (-30, 5.5),
                        (-45, 6.0)])
"""Roundness radius (mm) of the dorsal ridge cross-section."""

LOBULE = {"y": -38.5, "z0": 17.3, "rx": 9.5, "ry": 9.0, "ry_up": 10.5, "rz": 12.5,
          "flare": 2.5}
"""Tip lobule: cap of an ellipsoid centred at (0, y, z0) with semi-axes rx, ry (``ry_up``
above the centre), rz; its x semi-axis grows by ``flare`` below the centre."""

ALA = {"x": 11.0, "y": -41.5, "z0": 2.0, "rx": 5.6, "ry": 7.0, "rz": 12.0, "roll": 0.35}
"""Alar lobule (left; mirrored): ellipsoid cap, footprint rotated by ``roll`` rad."""

UNDERSIDE = {"y": -48.6, "z": 12.0, "slope": 0.27, "rim_rise": 1.2, "x_ala": 12.0}
"""Nasal base y = y0 + slope (z - z0) + rise(x): rises forwards, and by ``rim_rise``
beside the columella (the nostrils sit higher than the columella); beyond ``x_ala`` it
falls away so the alar lobules round off by themselves."""

NOSTRIL_CENTER = np.array([6.0, 0.0, 16.3])
NOSTRIL_AXES = np.array([5.3, 3.0])
NOSTRIL_YAW = np.deg2rad(26.0)
NOSTRIL_DEPTH_MM = 7.0
MF_HALF_WIDTH_MM = 10.0
"""Half of the mf-mf distance used to place maxillofrontale."""
RIM_RING = 1.12
"""Nostril region = cup plus the base within this elliptical radius (border loop)."""


def _cap(q2: np.ndarray, z0: float, rz: float, soft: float = 0.12) -> np.ndarray:
    """Ellipsoid cap ``z0 + rz sqrt(1 - q2)`` with a soft rim.

    Where ``1 - q2 < soft`` the square root continues along its tangent (C1), so the cap
    meets what it is blended with at a finite slope and keeps falling outside.
    """
    s = 1.0 - q2
    r = np.sqrt(soft)
    return z0 + rz * np.where(s > soft, np.sqrt(np.maximum(s, soft)), r + (s - soft) / (2 * r))


def _ridge(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Dorsum and sidewalls; below the alar groove the sidewalls retreat behind the alae."""
    s = _RIDGE_SLOPE(y)
    rho = _RIDGE_ROUND(y)
    return _RIDGE_Z(y) - s * (np.sqrt(x * x + rho * rho) - rho)


def _lobule(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Tip lobule; its lower half widens into the soft triangles over the nostrils."""
    L = LOBULE
    rx = L["rx"] + L["flare"] * _smoothstep((L["y"] - y) / 6.0)
    ry = np.where(y > L["y"], L["ry_up"], L["ry"])
    q2 = (x / rx) ** 2 + ((y - L["y"]) / ry) ** 2
    return _cap(q2, L["z0"], L["rz"])


def _ala(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    A = ALA
    ax = np.abs(x) - A["x"]
    ay = y - A["y"]
    c, s = np.cos(A["roll"]), np.sin(A["roll"])
    u, v = c * ax + s * ay, -s * ax + c * ay
    q2 = (u / A["rx"]) ** 2 + (v / A["ry"]) ** 2
    return _cap(q2, A["z0"], A["rz"], soft=0.3)


def _rise(x: np.ndarray) -> np.ndarray:
    U = UNDERSIDE
    ax = np.abs(x)
    return U["rim_rise"] * _smoothstep((ax - 2.5) / 4.0) \
        - 15.0 * _smoothstep((ax - U["x_ala"]) / 5.0)


def _underside_y(x: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Height y of the nasal base below the point (x, z)."""
    U = UNDERSIDE
    return U["y"] + U["slope"] * (z - U["z"]) + _rise(x)


def _underside(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The nasal base as a height field: z where the base passes height y."""
    U = UNDERSIDE
    return U["z"] + (y - U["y"] - _rise(x)) / U["slope"]


def nose_parts(x: np.ndarray, y: np.ndarray) -> dict[str, np.ndarray]:
    """Height fields (mm) of the nose primitives at (x, y)."""
    return {"ridge": _ridge(x, y), "lobule": _lobule(x, y), "ala": _ala(x, y),
            "under": _underside(x, y)}


def _blend_k(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Blend radii (mm): ala/sidewall (alar groove), nose/face (crease near the alae)."""
    ax = np.abs(x)
    k_groove = 1.6 + 4.0 * _smoothstep((10.0 - ax) / 4.0)
    near_ala = _smoothstep((ax - 9.0) / 4.0) * _smoothstep((-36.0 - y) / 4.0)
    k_face = 4.5 - 3.3 * near_ala
    return k_groove, k_face


def nose_height(x: np.ndarray, y: np.ndarray,
                parts: dict[str, np.ndarray] | None = None) -> np.ndarray:
    """Depth z (mm) of the external nose alone at (x, y) (very low outside it)."""
    p = nose_parts(x, y) if parts is None else parts
    k_groove, _ = _blend_k(x, y)
    front = _smax(p["ridge"], p["lobule"], 5.0)
    front = _smax(front, p["ala"], k_groove)
    return _smin(front, p["under"], 2.2)


def surface_height(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Depth z (mm) of the whole face, nose included (before carving the nostrils)."""
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    _, k_face = _blend_k(x, y)
    return _smax(face_height(x, y), nose_height(x, y), k_face)


# --------------------------------------------------------------------------------------
# the mesh: graded symmetric triangulation of the face mask in the meshing plane
# --------------------------------------------------------------------------------------

OUTLINE_XY: tuple[tuple[float, float], ...] = (
    (0.0, 60.0), (20.0, 59.0), (36.0, 54.0), (50.0, 43.0), (60.0, 26.0), (66.0, 6.0),
    (70.0, -25.0), (68.0, -55.0), (60.0, -80.0), (47.0, -100.0), (28.0, -114.0),
    (0.0, -122.0))
"""Outline of the face mask (x, y) in mm, subject's left half, top to chin."""


def _outline_plane(step: float) -> np.ndarray:
    """(B, 2) mask outline in the meshing plane, a >= 0, top to bottom, ~``step`` apart."""
    pts = np.asarray(OUTLINE_XY)
    cy = -30.0
    phi = np.arctan2(pts[:, 1] - cy, pts[:, 0])
    r = np.hypot(pts[:, 0], pts[:, 1] - cy)
    # mirror to a closed loop so the spline crosses the midline at right angles
    phi_all = np.r_[phi, np.pi - phi[-2:0:-1]]
    r_all = np.r_[r, r[-2:0:-1]]
    phi_all = np.unwrap(np.r_[phi_all, phi_all[0]])
    order = np.argsort(-phi_all[:-1])
    ph = -phi_all[:-1][order]
    rr = r_all[order]
    ph = np.r_[ph, ph[0] + 2 * np.pi]
    rr = np.r_[rr, rr[0]]
    spl = CubicSpline(ph, rr, bc_type="periodic")
    t = np.linspace(-np.pi / 2, np.pi / 2, 2001)       # -phi from top (-pi/2) to bottom
    x = spl(t) * np.cos(-t)
    y = cy + spl(t) * np.sin(-t)
    x[[0, -1]] = 0.0
    P3 = np.stack([x, y, face_height(x, y)], axis=1)
    dense = _plane(P3)
    # keep the convex hull of the outline (the chin projects slightly concave), so the
    # planar Delaunay triangulation fills exactly the region it bounds
    full = np.concatenate([dense, dense * np.array([-1.0, 1.0])])
    hull = full[ConvexHull(full).vertices]
    hull = hull[hull[:, 0] >= 0.0]
    order = np.argsort(-np.arctan2(hull[:, 1] - hull[:, 1].mean(), hull[:, 0]))
    dense = hull[order]
    dense = np.concatenate([[[0.0, full[:, 1].max()]], dense, [[0.0, full[:, 1].min()]]])
    seg = np.linalg.norm(np.diff(dense, axis=0), axis=1)
    arc = np.r_[0.0, np.cumsum(seg)]
    n = max(int(np.ceil(arc[-1] / step)), 2)
    si = np.linspace(0.0, arc[-1], n + 1)
    out = np.stack([np.interp(si, arc, dense[:, 0]), np.interp(si, arc, dense[:, 1])], axis=1)
    out[[0, -1], 0] = 0.0
    return out


def _inside(P: np.ndarray, poly: np.ndarray, res: float = 0.1) -> np.ndarray:
    """(N,) bool: points (N, 2) inside the closed polygon (M, 2), on a ``res`` mm raster
    (points closer than ``res`` to the border may go either way)."""
    import cv2

    lo = poly.min(axis=0) - 1.0
    size = np.ceil((poly.max(axis=0) + 1.0 - lo) / res).astype(np.int64) + 1
    mask = np.zeros((int(size[1]), int(size[0])), dtype=np.uint8)
    pix = np.round((poly - lo) / res * 16.0).astype(np.int32)     # 4 fractional bits
    cv2.fillPoly(mask, [pix], 1, lineType=cv2.LINE_8, shift=4)
    ij = np.round((P - lo) / res).astype(np.int64)
    ok = (ij[:, 0] >= 0) & (ij[:, 0] < size[0]) & (ij[:, 1] >= 0) & (ij[:, 1] < size[1])
    out = np.zeros(len(P), dtype=bool)
    out[ok] = mask[ij[ok, 1], ij[ok, 0]] == 1
    return out


def _plane(P: np.ndarray) -> np.ndarray:
    """(..., 3) points -> (..., 2) meshing-plane coordinates (a, b)."""
    return np.stack([P[..., 0], P[..., 1] * E2[1] + P[..., 2] * E2[2]], axis=-1)


def _level(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Desired lattice level (0 fine, 1 medium, 2 coarse) at plane points."""
    upper_c = _plane(np.array([0.0, -15.0, 8.0]))
    lower_c = _plane(np.array([0.0, -42.0, 12.0]))
    qn = np.minimum((a / 15.0) ** 2 + ((b - upper_c[1]) / 20.0) ** 2,
                    (a / 25.0) ** 2 + ((b - lower_c[1]) / 14.0) ** 2)
    eye_c = _plane(np.array([31.0, -8.0, -11.0]))
    qe = ((np.abs(a) - eye_c[0]) / 19.0) ** 2 + ((b - eye_c[1]) / 12.0) ** 2
    lip_c = _plane(np.array([0.0, -71.0, 13.0]))
    ql = (a / 32.0) ** 2 + ((b - lip_c[1]) / 13.0) ** 2
    lev = np.full(a.shape, 2, dtype=np.int64)
    lev[(qn < 1.9) | (qe < 1.0) | (ql < 1.0)] = 1
    lev[qn < 1.0] = 0
    return lev


def _half_points() -> tuple[np.ndarray, int]:
    """Plane points with a >= 0: the mask outline first, then lattice points.

    Returns (N, 2) points and the number of outline points.
    """
    boundary = _outline_plane(LATTICE_MM[2][0])
    dense = _outline_plane(0.2)
    poly = np.concatenate([dense, dense[-2:0:-1] * np.array([-1.0, 1.0])])
    tree = cKDTree(dense)
    lo, hi = dense.min(axis=0), dense.max(axis=0)
    pts = []
    for lev, (sa, sb) in enumerate(LATTICE_MM):
        k = np.arange(0, int(hi[0] / sa) + 2)
        j = np.arange(int(np.floor(lo[1] / sb)) - 2, int(np.ceil(hi[1] / sb)) + 3)
        K, J = np.meshgrid(k, j, indexing="ij")
        a = (K * sa).ravel()
        b = ((J + 0.5 * (K % 2)) * sb).ravel()
        lv = _level(a, b)
        keep = (lv == lev) if lev < 2 else (lv >= 2)
        cand = np.stack([a[keep], b[keep]], axis=1)
        cand = cand[_inside(cand, poly)]
        dist, _ = tree.query(cand)
        pts.append(cand[dist > 0.6 * sa])
    interior = np.concatenate(pts)
    interior = interior[np.lexsort((interior[:, 1], interior[:, 0]))]
    return np.concatenate([boundary, interior]), len(boundary)


def _delaunay_half(P: np.ndarray, n_boundary: int) -> np.ndarray:
    """(F, 3) triangles of half-plane points P (N, 2), counter-clockwise in (a, b).

    ``P[:n_boundary]`` is the outline (top to bottom); triangles outside the region it
    bounds with the midline (slight concavities of the outline) are dropped.
    """
    tri = Delaunay(P, qhull_options="Qbb Qc Qz Q12").simplices.astype(np.int64)
    outline = P[:n_boundary]
    poly = np.concatenate([outline, outline[-2:0:-1] * np.array([-1.0, 1.0])])
    cen = P[tri].mean(axis=1)
    tri = tri[_inside(cen, poly) | (np.abs(cen[:, 0]) < 1e-9)]
    area = _signed_area(P, tri)
    tri = tri[np.abs(area) > 1e-9]
    area = area[np.abs(area) > 1e-9]
    tri[area < 0] = tri[area < 0][:, [0, 2, 1]]
    return tri


def _signed_area(P: np.ndarray, tri: np.ndarray) -> np.ndarray:
    A = P[tri]
    return (A[:, 1, 0] - A[:, 0, 0]) * (A[:, 2, 1] - A[:, 0, 1]) \
        - (A[:, 2, 0] - A[:, 0, 0]) * (A[:, 1, 1] - A[:, 0, 1])


def _interior_edges(F: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Interior edges of a consistently oriented triangle mesh.

    Returns (E, 2) edges (i, j) as they run in the first triangle, and the two
    triangles (E,) t1 (containing i -> j) and t2 (containing j -> i).
    """
    he = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    ft = np.tile(np.arange(len(F)), 3)
    key = np.minimum(he[:, 0], he[:, 1]) * (F.max() + 1) + np.maximum(he[:, 0], he[:, 1])
    order = np.argsort(key, kind="stable")
    ks = key[order]
    pair = np.flatnonzero(ks[1:] == ks[:-1])
    h1, h2 = order[pair], order[pair + 1]
    return he[h1], ft[h1], ft[h2]


def _flip_to_delaunay_3d(P2: np.ndarray, X: np.ndarray, F: np.ndarray,
                         max_rounds: int = 60) -> np.ndarray:
    """Flip edges until the triangulation is Delaunay on the surface (3D angles).

    A lattice triangulated in the plane gives long thin triangles where the surface is
    steep; flipping to the 3D-Delaunay diagonals removes the shading streaks. Only flips
    that keep both triangles counter-clockwise in the plane (``P2``) are made, so the mesh
    stays an embedding over the plane.

    Args:
        P2: (N, 2) plane points; X: (N, 3) surface points; F: (M, 3) triangles (CCW in P2).
    Returns:
        (M, 3) triangles.
    """
    F = F.copy()
    for _ in range(max_rounds):
        E, t1, t2 = _interior_edges(F)
        i, j = E[:, 0], E[:, 1]
        # opposite vertices: k in t1, l in t2
        k = F[t1].sum(axis=1) - i - j
        l_ = F[t2].sum(axis=1) - i - j

        def cot(at: np.ndarray, p: np.ndarray, q: np.ndarray) -> np.ndarray:
            u, v = X[p] - X[at], X[q] - X[at]
            return np.einsum("ij,ij->i", u, v) / np.maximum(
                np.linalg.norm(np.cross(u, v), axis=1), 1e-12)

        bad = cot(k, i, j) + cot(l_, i, j) < -1e-9
        if not bad.any():
            break
        # new triangles (i, l, k) and (l, j, k) must be counter-clockwise in the plane
        n1 = np.stack([i, l_, k], axis=1)
        n2 = np.stack([l_, j, k], axis=1)
        ok = bad & (_signed_area(P2, n1) > 1e-9) & (_signed_area(P2, n2) > 1e-9)
        cand = np.flatnonzero(ok)
        if cand.size == 0:
            break
        # flip an independent set: every triangle in at most one flip this round
        viol = (cot(k, i, j) + cot(l_, i, j))[cand]
        cand = cand[np.argsort(viol, kind="stable")]
        used = np.zeros(len(F), dtype=bool)
        take = []
        for e in cand:
            if not used[t1[e]] and not used[t2[e]]:
                used[t1[e]] = used[t2[e]] = True
                take.append(e)
        take = np.asarray(take, dtype=np.int64)
        F[t1[take]] = n1[take]
        F[t2[take]] = n2[take]
    return F


def _mirror(P2: np.ndarray, X: np.ndarray, F: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mirror a half mesh (a >= 0) across the midline a = 0.

    Returns plane points (N', 2), surface points (N', 3) (the half, then mirrored copies
    of the a > 0 points) and triangles (2M, 3), counter-clockwise seen from outside.
    """
    on_mid = np.abs(P2[:, 0]) < 1e-9
    side = np.flatnonzero(~on_mid)
    mirror_idx = np.arange(len(P2))
    mirror_idx[side] = len(P2) + np.arange(len(side))
    flip = np.array([-1.0, 1.0, 1.0])
    F_m = mirror_idx[F][:, [0, 2, 1]]
    return (np.concatenate([P2, P2[side] * flip[:2]]), np.concatenate([X, X[side] * flip]),
            np.concatenate([F, F_m]))


# --------------------------------------------------------------------------------------
# ray casting
# --------------------------------------------------------------------------------------

def _ray_hits(ab: np.ndarray,
              height: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
              iterations: int = 34) -> np.ndarray:
    """(N,) ray parameter t where the ray ``a e1 + b e2 + t d`` meets ``z = height(x, y)``.

    Along the ray ``z - height`` increases monotonically wherever the surface faces the
    meshing direction (``dz/dy > -cot(tilt)``), so bisection finds the unique hit.
    """
    height = surface_height if height is None else height
    a, b = ab[:, 0], ab[:, 1]
    lo = np.full(len(ab), -170.0)
    hi = np.full(len(ab), 170.0)
    for _ in range(iterations):
        t = 0.5 * (lo + hi)
        y = b * E2[1] + t * D[1]
        z = b * E2[2] + t * D[2]
        above = z > height(a, y)
        hi = np.where(above, t, hi)
        lo = np.where(above, lo, t)
    return 0.5 * (lo + hi)


def _points(ab: np.ndarray, t: np.ndarray) -> np.ndarray:
    return ab[..., 0:1] * E1 + ab[..., 1:2] * E2 + t[..., None] * D


# --------------------------------------------------------------------------------------
# nostrils
# --------------------------------------------------------------------------------------

def _nostril_frame(side: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Centre (x, z) (2,), long axis u (2,), short axis v (2,) in the (x, z) plane, and
    the cup direction (3,) of the nostril on side ``side`` (+1 left, -1 right).

    The long axis points forwards and towards the midline.
    """
    c = np.array([side * NOSTRIL_CENTER[0], NOSTRIL_CENTER[2]])
    u = np.array([-side * np.sin(NOSTRIL_YAW), np.cos(NOSTRIL_YAW)])
    v = np.array([u[1], -u[0]])
    cup = np.array([0.0, 0.94, -0.34])
    return c, u, v, cup / np.linalg.norm(cup)


def _nostril_rho(X: np.ndarray, side: float) -> np.ndarray:
    """(N,) elliptical radius of points (N, 3) in the nostril footprint (1 on the rim)."""
    c, u, v, _ = _nostril_frame(side)
    q = X[:, [0, 2]] - c
    return np.sqrt(((q @ u) / NOSTRIL_AXES[0]) ** 2 + ((q @ v) / NOSTRIL_AXES[1]) ** 2)


def _on_underside(X: np.ndarray) -> np.ndarray:
    """(N,) bool: the surface at X is the nasal base plane (not the lobule or the lip)."""
    dy = X[:, 1] - _underside_y(X[:, 0], X[:, 2])
    return (dy > -2.0) & (dy < 6.0)


def _carve_nostrils(X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Move the vertices of the two nostril footprints into half-ellipsoid cups.

    A vertex at elliptical radius ``r`` < 1 moves out to radius ``sin(pi r / 2)`` and up
    into the nose by ``depth cos(pi r / 2)``, so the cup wall is sampled evenly and meets
    the nasal base at a sharp rim.

    Args:
        X: (N, 3) surface points before carving.
    Returns:
        carved points (N, 3), and (N,) int64 nostril side of each vertex (+1 left,
        -1 right, 0 none).
    """
    X = X.copy()
    which = np.zeros(len(X), dtype=np.int64)
    under = _on_underside(X)
    for side in (1.0, -1.0):
        c, u, v, cup = _nostril_frame(side)
        rho = _nostril_rho(X, side)
        sel = (rho <= 1.0) & under & (np.sign(X[:, 0]) == side)
        if not sel.any():
            continue
        r = rho[sel]
        q = X[sel][:, [0, 2]] - c
        scale = np.where(r > 1e-9, np.sin(0.5 * np.pi * r) / np.maximum(r, 1e-9), 1.0)
        depth = NOSTRIL_DEPTH_MM * np.cos(0.5 * np.pi * r)
        Y = X[sel]
        Y[:, [0, 2]] = c + q * scale[:, None]
        X[sel] = Y + depth[:, None] * cup
        which[sel] = int(side)
        # the ring just outside the rim (still on the nasal base) belongs to the nostril
        # region too, so the region's border is a smooth loop on the base, not the rim's
        # zig-zag of partly carved vertices
        dy = X[:, 1] - _underside_y(X[:, 0], X[:, 2])
        ring = (rho > 1.0) & (rho <= RIM_RING) & (dy > -0.7) & (dy < 4.0) \
            & (np.sign(X[:, 0]) == side)
        which[ring] = int(side)
    return X, which


# --------------------------------------------------------------------------------------
# assembly
# --------------------------------------------------------------------------------------

@dataclass(frozen=True)
class GenericMesh:
    """The mean face mesh and what the model annotations are computed from.

    Attributes:
        V: (N, 3) float64 vertices, mm.
        F: (M, 3) int64 triangles, counter-clockwise seen from outside.
        V_uncarved: (N, 3) vertices before the nostrils were carved.
        nostril_side: (N,) int64 +1 / -1 inside the left / right nostril, else 0.
        mirror: (N,) int64 index of each vertex's mirror image across x = 0.
    """

    V: np.ndarray
    F: np.ndarray
    V_uncarved: np.ndarray
    nostril_side: np.ndarray
    mirror: np.ndarray


@functools.lru_cache(maxsize=1)
def generic_mesh() -> GenericMesh:
    """Build the mean face mesh (deterministic; a fraction of a second; cached, read-only)."""
    half, n_outline = _half_points()
    X0 = _points(half, _ray_hits(half))
    X, which = _carve_nostrils(X0)
    F = _flip_to_delaunay_3d(half, X, _delaunay_half(half, n_outline))
    _, V, F = _mirror(half, X, F)
    _, V0, _ = _mirror(half, X0, F[:0])
    side = np.abs(half[:, 0]) >= 1e-9
    n_half, n_side = len(half), int(side.sum())
    mirror = np.arange(n_half + n_side)
    mirror[np.flatnonzero(side)] = n_half + np.arange(n_side)
    mirror[n_half:] = np.flatnonzero(side)
    which = np.concatenate([which, -which[side]])
    which = _largest_patches(F, which)
    for arr in (V, F, V0, which, mirror):
        arr.flags.writeable = False
    return GenericMesh(V, F, V0, which, mirror)


def _largest_patches(F: np.ndarray, label: np.ndarray) -> np.ndarray:
    """Keep, for every non-zero label, only its largest edge-connected set of vertices."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    out = np.zeros_like(label)
    e = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    for lab in np.unique(label[label != 0]):
        ids = np.flatnonzero(label == lab)
        pos = np.full(len(label), -1)
        pos[ids] = np.arange(len(ids))
        ee = e[(pos[e[:, 0]] >= 0) & (pos[e[:, 1]] >= 0)]
        A = coo_matrix((np.ones(len(ee)), (pos[ee[:, 0]], pos[ee[:, 1]])),
                       shape=(len(ids), len(ids)))
        _, comp = connected_components(A, directed=False)
        out[ids[comp == np.argmax(np.bincount(comp))]] = lab
    return out


# --------------------------------------------------------------------------------------
# landmarks and regions
# --------------------------------------------------------------------------------------

def _membership(X: np.ndarray) -> np.ndarray:
    """(N,) height (mm) of the nose above the face without it at the points' (x, y)."""
    return nose_height(X[:, 0], X[:, 1]) - face_height(X[:, 0], X[:, 1])


def _farthest_from_chord(P: np.ndarray, a: np.ndarray, b: np.ndarray,
                         toward: np.ndarray) -> int:
    """Index of the point (rows of P) farthest from line a-b on the side of ``toward``."""
    u = (b - a) / np.linalg.norm(b - a)
    q = P - a
    perp = q - np.outer(q @ u, u)
    return int(np.argmax(perp @ toward))


def _nostril_rim(F: np.ndarray, nostril: np.ndarray) -> np.ndarray:
    """(R,) vertices of the nostril region that have a neighbour outside it."""
    inside = np.zeros(int(F.max()) + 1, dtype=bool)
    inside[nostril] = True
    e = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    cross = inside[e[:, 0]] & ~inside[e[:, 1]]
    return np.unique(e[cross, 0])


def find_landmarks(mesh: GenericMesh) -> dict[str, int]:
    """Vertex of each of the 21 landmarks of SPEC §1 on the mean mesh.

    Every landmark is found from its anatomical definition on the surface (most anterior,
    deepest, most lateral, ...); left ones on x > 0, right ones are their mirror images.
    """
    V, F = mesh.V, mesh.F
    x, y, z = V[:, 0], V[:, 1], V[:, 2]
    mid = np.flatnonzero(np.abs(x) < 1e-9)
    m = _membership(mesh.V_uncarved)
    nostril = np.flatnonzero(mesh.nostril_side != 0)
    lm: dict[str, int] = {}

    def pick(cands: np.ndarray, score: np.ndarray) -> int:
        return int(cands[int(np.argmax(score))])

    lm["prn"] = pick(mid, z[mid])
    p = V[lm["prn"]]
    root = mid[(y[mid] > p[1] + 25.0) & (y[mid] < p[1] + 55.0)]
    lm["n"] = pick(root, -z[root])
    n_ = V[lm["n"]]
    brow = mid[(y[mid] > n_[1]) & (y[mid] < n_[1] + 25.0)]
    lm["g"] = pick(brow, z[brow])
    below = mid[(y[mid] < p[1] - 3.0) & (y[mid] > p[1] - 22.0)]
    lm["sn"] = pick(below, -z[below])
    s_ = V[lm["sn"]]
    tipc = mid[(y[mid] < p[1]) & (y[mid] > s_[1]) & (z[mid] > s_[2])]
    lm["c"] = int(tipc[_farthest_from_chord(V[tipc], p, s_, np.array([0.0, -1.0, 1.0]))])
    dors = mid[(y[mid] < n_[1]) & (y[mid] > p[1])]
    frac = (n_[1] - y[dors]) / (n_[1] - p[1])
    lm["r"] = int(dors[np.argmin(np.abs(frac - 0.55))])
    upper = dors[(frac > 0.15) & (frac < 0.5)]
    lm["k"] = int(upper[_farthest_from_chord(V[upper], n_, p, np.array([0.0, 0.6, 0.8]))])

    left = np.flatnonzero(x > 1e-9)
    # maxillofrontale: on the medial orbital rim at the height of n; this face has no
    # distinct frontonasal-orbital groove there, so the rim point is taken at the
    # population half-distance (mf-mf about 20 mm, Farkas)
    target = np.array([MF_HALF_WIDTH_MM, n_[1]])
    lm["mf_l"] = int(left[np.argmin(np.linalg.norm(V[left][:, :2] - target, axis=1))])
    parts = nose_parts(mesh.V_uncarved[:, 0], mesh.V_uncarved[:, 1])
    front = _smax(parts["ridge"], parts["lobule"], 5.0)
    ala_dom = left[(parts["ala"][left] > front[left]) & (mesh.nostril_side[left] == 0)]
    # alare: most lateral point of the alar lobule standing clear of the cheek
    ala = ala_dom[m[ala_dom] > 1.5]
    lm["al_l"] = pick(ala, x[ala])
    al = V[lm["al_l"]]
    # alar curvature point: deepest (most posterior) point of the crease where the ala
    # meets the cheek
    near_ala = left[(parts["ala"][left] > front[left] - 1.5) & (mesh.nostril_side[left] == 0)]
    crease = near_ala[(np.abs(m[near_ala]) < 0.5) & (y[near_ala] <= al[1] - 1.0)]
    lm["ac_l"] = pick(crease, -z[crease])
    groove = left[(np.abs(parts["ala"][left] - front[left]) < 0.5) & (m[left] > 1.0)
                  & (y[left] > al[1])]
    lm["int_l"] = pick(groove, y[groove] + z[groove])
    # nostril rim: sill (most posterior) and the arch apex seen from the front (highest)
    rim = _nostril_rim(F, nostril)
    rim_l = rim[x[rim] > 0]
    lm["alpp_l"] = pick(rim_l, -z[rim_l])
    top = rim_l[y[rim_l] >= y[rim_l].max() - 0.4]      # the flat top of the arch
    lm["md_l"] = int(top[np.argmin(np.linalg.norm(V[top] - V[top].mean(axis=0), axis=1))])
    # al': on the bottom-view outline (largest x per depth band), the first point from
    # al towards prn where the tip lobule takes over from the ala
    base = left[(m[left] > 0.3) & (y[left] < p[1] + 3.0) & (z[left] > al[2])
                & (z[left] < p[2]) & (mesh.nostril_side[left] == 0)]
    bands = np.floor(z[base] / 0.75).astype(np.int64)
    order = np.lexsort((-x[base], bands))
    first = np.r_[True, bands[order][1:] != bands[order][:-1]]
    outline = base[order][first]                       # ordered from al towards prn
    lob = parts["lobule"][outline] >= parts["ala"][outline]
    lm["alp_l"] = int(outline[int(np.argmax(lob))] if lob.any() else outline[-1])
    for k in [k for k in lm if k.endswith("_l")]:
        lm[k[:-2] + "_r"] = int(mesh.mirror[lm[k]])
    return {k: lm[k] for k in LANDMARK_IDS}


def nose_region(mesh: GenericMesh, landmarks: dict[str, int]) -> np.ndarray:
    """(N,) sorted vertex ids of the external nose, radix to subnasale and alar creases.

    The connected part around prn of the surface where the nose's height field is above
    the face's, or less than 0.5 mm below it (so the alar creases and the nasofacial
    junction are included), below the radix line through n and the two mf, plus the
    strip between the mf and the nostrils; holes filled.
    """
    from scipy.sparse.csgraph import connected_components

    from naseview.facemodel import meshcurves as mc

    V, F, lm = mesh.V, mesh.F, landmarks
    m = _membership(mesh.V_uncarved)
    y_top = max(V[lm["n"], 1], V[lm["mf_l"], 1]) + 0.5
    x_mf = abs(V[lm["mf_l"], 0]) + 0.5
    keep = (m >= -0.5) & (V[:, 1] <= y_top)
    keep |= (V[:, 1] <= y_top) & (np.abs(V[:, 0]) <= x_mf) & (V[:, 1] >= V[lm["sn"], 1])
    keep[mesh.nostril_side != 0] = True
    keep[list(lm.values())] = True
    A = mc.vertex_adjacency(len(V), F)
    ids = np.flatnonzero(keep)
    _, comp = connected_components(A[ids][:, ids], directed=False)
    main = comp[np.searchsorted(ids, lm["prn"])]
    region = ids[comp == main]
    # fill holes: everything not reachable from the mesh border without crossing the region
    inside = np.zeros(len(V), dtype=bool)
    inside[region] = True
    rest = np.flatnonzero(~inside)
    _, comp = connected_components(A[rest][:, rest], directed=False)
    border = np.unique(mc.region_boundary_loops(F, np.arange(len(V)))[0])
    outer = np.unique(comp[np.searchsorted(rest, border[~inside[border]])])
    inside[rest[~np.isin(comp, outer)]] = True
    return np.flatnonzero(inside)


# --------------------------------------------------------------------------------------
# modes: smooth localised deformation fields (derivatives of the parametric face)
# --------------------------------------------------------------------------------------

def _nose_weight(mesh: GenericMesh) -> np.ndarray:
    """(N,) 1 on the external nose, 0 on the face beyond its creases, smooth in between."""
    m = _membership(mesh.V_uncarved)
    return _smoothstep((m + 2.5) / 6.5)


def _mode_fields(mesh: GenericMesh, lm: dict[str, int]) -> dict[str, np.ndarray]:
    """Raw (uncalibrated) displacement field (N, 3) of every mode on the mean mesh."""
    V = mesh.V
    x, y, z = V[:, 0], V[:, 1], V[:, 2]
    P = {k: V[i] for k, i in lm.items()}
    w = _nose_weight(mesh)
    L = float(np.linalg.norm(P["prn"] - P["n"]))
    u = (P["prn"] - P["n"]) / L                         # dorsal direction, down-forward
    n_d = np.array([0.0, u[2], -u[1]])                   # normal to it, up-forward
    s = ((V - P["n"]) @ u) / L                           # 0 at n, 1 at prn
    fields: dict[str, np.ndarray] = {}
    ac_z = 0.5 * (P["ac_l"][2] + P["ac_r"][2])
    h = np.clip((z - ac_z) / (P["prn"][2] - ac_z), 0.0, 1.0)     # 0 at ac, 1 at prn
    # nose_length: the tip slides along the dorsum; radix and alar bases stay
    fields["nose_length"] = (w * _smoothstep(s) * _smoothstep(1.25 * h))[:, None] * u
    # projection: forwards, growing from the alar creases to the tip
    fields["projection"] = (w * _smoothstep(h))[:, None] * np.array([0.0, 0.0, 1.0])
    # dorsal_hump: a bump on the dorsum centred between k and r
    s0 = 0.5 * (((P["k"] - P["n"]) @ u) + ((P["r"] - P["n"]) @ u)) / L
    bump = _gauss((s - s0) / 0.17) * _gauss(x / 6.0)
    fields["dorsal_hump"] = (w * bump)[:, None] * n_d
    # tip_width: lateral spread of the tip lobule (and soft triangles)
    tip = P["prn"] + np.array([0.0, -2.0, -7.0])
    lob = _gauss(np.linalg.norm((V - tip) / np.array([11.0, 7.0, 9.0]), axis=1))
    fields["tip_width"] = (w * lob * x)[:, None] * np.array([1.0, 0.0, 0.0])
    # alar_width: the alae and the lower sidewalls move outwards
    y_int = P["int_l"][1]
    low = _smoothstep((y_int + 4.0 - y) / 8.0)
    lateral = _smoothstep((np.abs(x) - 10.0) / 7.0) * np.sign(x)
    fields["alar_width"] = (w * low * lateral)[:, None] * np.array([1.0, 0.0, 0.0])
    # nostril_size: the nostrils grow in the plane of the nasal base, cups included
    f = np.zeros_like(V)
    X0 = mesh.V_uncarved
    dy = X0[:, 1] - _underside_y(X0[:, 0], X0[:, 2])
    base = _smoothstep((dy + 2.0) / 1.5) * (dy < 8.0)
    for side in (1.0, -1.0):
        rho = _nostril_rho(X0, side)
        c, _, _, _ = _nostril_frame(side)
        c3 = np.array([c[0], _underside_y(c[0:1], c[1:2])[0], c[1]])
        wn = _smoothstep((1.6 - rho) / 0.6) * base * (np.sign(x) == side)
        q = V - c3
        q[:, 1] *= 0.5                                   # mostly in the base plane
        f += wn[:, None] * q
    fields["nostril_size"] = f
    # whole-face modes leave the nose where it is
    rest = 1.0 - _smoothstep((_membership(mesh.V_uncarved) + 4.0) / 3.0)
    fields["face_width"] = (x * _smoothstep((np.abs(x) - 16.0) / 16.0))[:, None] \
        * np.array([1.0, 0.0, 0.0])
    y_sn = P["sn"][1]
    below = 0.5 * ((y_sn - 2.0 - y) + np.sqrt((y_sn - 2.0 - y) ** 2 + 9.0))
    fields["face_height"] = (rest * below)[:, None] * np.array([0.0, -1.0, 0.0])
    brow = _gauss((y - P["g"][1]) / 9.0) * _gauss(x / 30.0)
    fields["brow_prominence"] = (rest * brow)[:, None] * np.array([0.0, 0.0, 1.0])
    return fields


Measurement = Callable[[np.ndarray], float]


def _mode_measurements(mesh: GenericMesh, lm: dict[str, int]) -> dict[str, Measurement]:
    """Measurement (mm) defining each mode, as a function of the vertices (N, 3)."""
    V0 = mesh.V
    left = np.flatnonzero(mesh.nostril_side == 1)
    rim = _nostril_rim(mesh.F, left)
    c, _, v, _ = _nostril_frame(1.0)
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


def _basis(mesh: GenericMesh, lm: dict[str, int]) -> np.ndarray:
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


@functools.lru_cache(maxsize=1)
def generic_face_model() -> FaceModel:
    """The built-in generic face (deterministic; built in under a second, then cached).

    Returns:
        FaceModel ``"generic"``: mean (N, 3) mm in the SPEC axes (origin at the design's
        nasion), CCW faces, basis (9, N, 3) with modes :data:`NOSE_MODES` +
        :data:`FACE_MODES` (a unit coefficient is about one population SD), the 21
        landmark vertices, nose, nostril and curve vertices. Arrays are read-only
        (shared by every caller).
    """
    from naseview.facemodel.meshcurves import curve_paths

    mesh = generic_mesh()
    lm = find_landmarks(mesh)
    nostrils = np.flatnonzero(mesh.nostril_side != 0)
    curves = curve_paths(mesh.V, mesh.F, lm, nostrils)
    model = FaceModel(
        name="generic", mean=mesh.V, faces=mesh.F, basis=_basis(mesh, lm),
        landmark_vertices=lm, nose_vertices=nose_region(mesh, lm),
        nostril_vertices=nostrils, curve_vertices=curves,
        mode_names=NOSE_MODES + FACE_MODES, credit=CREDIT)
    for arr in (model.mean, model.faces, model.basis, model.nose_vertices,
                model.nostril_vertices, *model.curve_vertices.values()):
        arr.flags.writeable = False
    return model
