"""The 21 nasal landmarks and 2 helper clicks of SPEC §1, the one table everything uses.

The landmarks are the paper's (section 3.2, Fig. 2; the ``add`` helpers, section 3.3.2);
this module is also the one home of the curve tables (which landmarks each SPEC §5 curve
passes through, which photo it is taken from: paper section 3.3, Fig. 14) and of which
landmarks each photo shows.

Suffix ``_l`` / ``_r`` is the *subject's* left / right. In the SPEC frame the subject's
left is +x (see :mod:`naseview.camera`).

Example
-------
>>> from naseview.landmarks import LANDMARKS, LANDMARK_IDS, partner
>>> len(LANDMARK_IDS)
21
>>> partner("al_l")
'al_r'
>>> LANDMARKS["prn"].paper
'prn'
"""

from __future__ import annotations

from dataclasses import dataclass

VIEWS: tuple[str, ...] = ("front", "left", "right", "bottom")
"""The four photos every case has, SPEC §2. ``left`` is the camera on the subject's left
side."""

OBLIQUE_VIEWS: tuple[str, ...] = ("oblique_left", "oblique_right")
"""The two optional three-quarter photos, SPEC §2: the camera about 45 degrees from the
front towards the subject's left (``oblique_left``) or right (``oblique_right``)."""

ALL_VIEWS: tuple[str, ...] = VIEWS + OBLIQUE_VIEWS
"""Every photo a case may have, in SPEC order: the four, then the obliques."""


@dataclass(frozen=True)
class Landmark:
    """One landmark of SPEC §1.

    Attributes:
        id: SPEC id, e.g. ``"al_l"``.
        paper: the paper's name (``"al"``, ``"al'"``, ...).
        description: one line, soft-tissue definition.
        partner: id of the mirrored landmark (``None`` on the midline).
        side: ``"l"``, ``"r"`` or ``"mid"``.
        curves: names (SPEC §5) of the boundary curves through this landmark.
        helper: True for the 2D-only ``add`` clicks (never triangulated).
    """

    id: str
    paper: str
    description: str
    partner: str | None
    side: str
    curves: tuple[str, ...]
    helper: bool = False


def _pair(base: str, paper: str, description: str, curves_l: tuple[str, ...],
          curves_r: tuple[str, ...], helper: bool = False) -> list[Landmark]:
    return [
        Landmark(f"{base}_l", paper, description + " (subject's left)", f"{base}_r", "l",
                 curves_l, helper),
        Landmark(f"{base}_r", paper, description + " (subject's right)", f"{base}_l", "r",
                 curves_r, helper),
    ]


_TABLE: list[Landmark] = [
    Landmark("g", "g", "glabella: most prominent midline point between the eyebrows; origin",
             None, "mid", ("mid",)),
    Landmark("n", "n", "nasion: deepest midline point of the frontonasal angle",
             None, "mid", ("mid",)),
    Landmark("k", "k", "kyphion: most prominent point of the bony dorsum, between n and r",
             None, "mid", ("mid",)),
    Landmark("r", "r", "rhinion: junction of bony and cartilaginous dorsum on the midline",
             None, "mid", ("mid",)),
    Landmark("prn", "prn", "pronasale: most anterior point of the nasal tip",
             None, "mid", ("mid", "bottom")),
    Landmark("c", "c", "columella point: lobule/columella turning point below prn",
             None, "mid", ("mid", "c")),
    Landmark("sn", "sn", "subnasale: where the columella meets the upper lip",
             None, "mid", ("mid",)),
    *_pair("mf", "mf", "maxillofrontale: medial orbital rim beside the nasal root",
           ("side_l",), ("side_r",)),
    *_pair("int", "int", "upper-anterior end of the alar groove on the nasal sidewall",
           ("ala_l", "side_l"), ("ala_r", "side_r")),
    *_pair("al", "al", "alare: most lateral point of the ala", ("ala_l", "bottom"),
           ("ala_r", "bottom")),
    *_pair("alp", "al'", "alar rim outline meets the tip lobule in the bottom view",
           ("bottom",), ("bottom",)),
    *_pair("alpp", "al''", "a point on the nostril border (nasal sill) in the bottom view",
           ("sill_l",), ("sill_r",)),
    *_pair("ac", "ac", "alar curvature point: deepest point of the alar crease",
           ("ala_l", "bottom"), ("ala_r", "bottom")),
    *_pair("md", "md", "apex of the alar-rim arch beside the lobule in the front view",
           ("c",), ("c",)),
    *_pair("add", "add", "helper click on the bottom-view outline between al' and prn",
           ("bottom",), ("bottom",), helper=True),
]

LANDMARKS: dict[str, Landmark] = {lm.id: lm for lm in _TABLE}
"""All 23 entries (21 landmarks + 2 helpers) by id, in SPEC order."""

LANDMARK_IDS: tuple[str, ...] = tuple(lm.id for lm in _TABLE if not lm.helper)
"""The 21 landmarks that are triangulated, in SPEC order."""

HELPER_IDS: tuple[str, ...] = tuple(lm.id for lm in _TABLE if lm.helper)
"""The 2D-only helper clicks ``add_l``, ``add_r``."""

ALL_IDS: tuple[str, ...] = LANDMARK_IDS + HELPER_IDS

MIDLINE_IDS: tuple[str, ...] = tuple(i for i in LANDMARK_IDS if LANDMARKS[i].side == "mid")

CURVE_NAMES: tuple[str, ...] = ("mid", "bottom", "ala_l", "ala_r", "c", "sill_l", "sill_r",
                                "side_l", "side_r")
"""Curve names of SPEC §5."""

CURVE_FAMILIES: dict[str, tuple[str, ...]] = {
    "mid": ("mid",), "bottom": ("bottom",), "ala": ("ala_l", "ala_r"), "c": ("c",),
    "sill": ("sill_l", "sill_r"), "side": ("side_l", "side_r"),
}
"""The paper's six boundary curves (Tables 4-5) and the SPEC curves that make each."""

CURVE_LANDMARKS: dict[str, tuple[str, ...]] = {
    "mid": ("g", "n", "k", "r", "prn", "c", "sn"),
    "bottom": ("ac_r", "al_r", "alp_r", "add_r", "prn", "add_l", "alp_l", "al_l", "ac_l"),
    "ala_l": ("ac_l", "al_l", "int_l"),
    "ala_r": ("ac_r", "al_r", "int_r"),
    "c": ("md_r", "c", "md_l"),
    "sill_l": ("alpp_l",),
    "sill_r": ("alpp_r",),
    "side_l": ("int_l", "mf_l"),
    "side_r": ("int_r", "mf_r"),
}
"""Landmarks each curve passes through, in order (SPEC §5). Sills are closed loops."""

CURVE_VIEWS: dict[str, tuple[str, ...]] = {
    "mid": ("left", "right"), "bottom": ("bottom",), "ala_l": ("front",),
    "ala_r": ("front",), "c": ("front",), "sill_l": ("bottom",), "sill_r": ("bottom",),
    "side_l": ("front",), "side_r": ("front",),
}
"""The photo(s) each curve is taken from (paper Fig. 14) and in which SPEC §7
``truth_boundaries.json`` gives its 2D ground truth."""

VIEW_LANDMARKS: dict[str, tuple[str, ...]] = {
    "front": LANDMARK_IDS,
    "left": MIDLINE_IDS + tuple(i for i in LANDMARK_IDS if i.endswith("_l")),
    "right": MIDLINE_IDS + tuple(i for i in LANDMARK_IDS if i.endswith("_r")),
    "bottom": ("prn", "c", "sn", "al_l", "al_r", "alp_l", "alp_r", "alpp_l", "alpp_r",
               "ac_l", "ac_r", "md_l", "md_r", "add_l", "add_r"),
    # a 3/4 photo: the midline, its own side (the nasal root, the sidewall, the alar
    # groove and crease, the nostril's rim from the side, as a profile shows them) and
    # the far side's medial canthus and alar arch
    "oblique_left": MIDLINE_IDS + ("mf_l", "int_l", "al_l", "alp_l", "alpp_l", "ac_l",
                                   "md_l", "mf_r", "md_r"),
    "oblique_right": MIDLINE_IDS + ("mf_r", "int_r", "al_r", "alp_r", "alpp_r", "ac_r",
                                    "md_r", "mf_l", "md_l"),
}
"""Which landmarks a surgeon can mark in each photo (those visible in it), the obliques'
included (:data:`ALL_VIEWS`)."""

TABLE1_DISTANCES: tuple[tuple[str, str], ...] = (
    ("mf_l", "mf_r"), ("int_l", "int_r"), ("alp_l", "alp_r"), ("ac_l", "ac_r"),
    ("md_l", "md_r"), ("g", "n"), ("n", "prn"), ("prn", "c"), ("int_l", "ac_l"),
    ("int_r", "ac_r"), ("c", "sn"),
)
"""The 11 landmark distances of the paper's Table 1 (SPEC §6)."""

TABLE2_DISTANCES: tuple[tuple[str, str], ...] = (("n", "prn"), ("prn", "sn"))
"""The profile pair of the paper's Table 2."""


def partner(landmark_id: str) -> str | None:
    """Mirrored landmark id (``"al_l"`` -> ``"al_r"``), ``None`` on the midline.

    Raises:
        KeyError: unknown id.
    """
    return LANDMARKS[landmark_id].partner


def mirror_id(name: str) -> str:
    """Swap a trailing ``_l`` / ``_r`` of a landmark or curve name; other names unchanged."""
    if name.endswith("_l"):
        return name[:-2] + "_r"
    if name.endswith("_r"):
        return name[:-2] + "_l"
    return name
