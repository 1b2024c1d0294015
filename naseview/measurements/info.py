"""What every measurement means: definition, patient sentence, inputs, ranges, source.

:data:`MEASUREMENT_INFO` lists every name :func:`naseview.measurements.clinical_measurements`
can return, in report order (groups ``profile``, ``tip``, ``width``, ``symmetry``, then the
paper's Table 1 ``distance`` keys). Ranges are adult values from the cited literature
(mostly young white North American adults or aesthetic-preference studies; other
populations differ); ``None`` where no norm is established. :func:`calliper_inputs` names
the measurements fixed by the calliper distances typed at intake (``case.json``
``scale_mm``), which are inputs, never findings.

Example
-------
>>> MEASUREMENT_INFO["nasofrontal_angle"].title, MEASUREMENT_INFO["nasofrontal_angle"].normal
('Nasofrontal angle', (115.0, 130.0))
>>> sorted(calliper_inputs(["al_l-al_r"]))
['al_l-al_r', 'nasal_width']
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass

from naseview.landmarks import LANDMARK_IDS, TABLE1_DISTANCES
from naseview.measurements.uncertainty import Estimate
from naseview.measurements.width import NAMED_DISTANCES, distance_key


@dataclass(frozen=True)
class MeasurementInfo:
    """What one measurement means.

    Attributes:
        name: key in the measurements dict.
        unit: ``"mm"``, ``"deg"`` or ``""`` (ratio / index).
        description: one-line definition for the surgeon (starts ``"<title>: "``).
        normal: typical adult range ``(low, high)`` or ``None`` when no norm is established.
        source: the reference of the definition and the ranges.
        title: short surgeon's title ("Nasofrontal angle").
        plain: one sentence for a patient, no jargon.
        uses: landmark ids, curve names and/or ``"mesh"`` it is computed from.
        normal_female, normal_male: ``(low, high)`` by sex where the literature gives it.
        group: ``"profile"``, ``"tip"``, ``"width"``, ``"symmetry"`` or ``"distance"``.
    """

    name: str
    unit: str
    description: str
    normal: tuple[float, float] | None = None
    source: str = ""
    title: str = ""
    plain: str = ""
    uses: tuple[str, ...] = ()
    normal_female: tuple[float, float] | None = None
    normal_male: tuple[float, float] | None = None
    group: str = "profile"


_FARKAS = ("Farkas LG et al., International anthropometric study of facial morphology in "
           "various ethnic groups/races, J Craniofac Surg 16(4):615-646, 2005 (young "
           "adults, North American white norms +-2 SD, both sexes; other populations "
           "differ, mostly wider noses)")
_POWELL = "Powell N, Humphreys B, Proportions of the Aesthetic Face, Thieme-Stratton, 1984"
_GOODE = ("Goode's method as reported by Powell & Humphreys 1984 and Byrd HS, Hobar PC, "
          "Rhinoplasty: a practical guide for surgical planning, Plast Reconstr Surg "
          "91(4):642-654, 1993")
_CRUMLEY = ("Crumley RL, Lanser M, Quantitative analysis of nasal tip projection, "
            "Laryngoscope 98(2):202-208, 1988")
_ARMIJO = ("Armijo BS, Brown M, Guyuron B, Defining the ideal nasolabial angle, Plast "
           "Reconstr Surg 129(3):759-764, 2012 (the 90-120 deg range 'usually stated in the "
           "literature'; by sex, the ideal mean +-1 SD of rated photographs, measured on the "
           "nostril axis, not the columella tangent used here)")
_AHMED = ("Ahmed O, Dhinsa A, Popenko N, Osann K, Crumley RL, Wong BJ, Population-based "
          "assessment of currently proposed ideals of nasal tip projection and rotation in "
          "young women, JAMA Facial Plast Surg 16(5):310-318, 2014 (columellar-facial angle "
          "as the rotation metric, 96-116 deg tested)")
_GUNTER = ("Gunter JP, Rohrich RJ, Friedman RM, Classification and correction of "
           "alar-columellar discrepancies in rhinoplasty, Plast Reconstr Surg 97(3):643-648, "
           "1996 (1-2 mm from the nostril's long axis to each of alar rim and columella)")
_MOWLAVI = ("Mowlavi A, Meldrum DG, Wilhelmi BJ, Implications for nasal recontouring: nasion "
            "position preferences as determined by a survey of white North Americans, "
            "Aesthetic Plast Surg 27:438-445, 2004 (nasion height is referred there to the corneal "
            "plane, which naseview does not have)")
_CANON = ("Farkas LG, Hreczko TA, Kolar JC, Munro IR, Vertical and horizontal proportions "
          "of the face in young adult North American Caucasians: revision of neoclassical "
          "canons, Plast Reconstr Surg 75(3):328-338, 1985 (orbitonasal canon en-en = al-al, "
          "valid in 40 % of young adults)")
_SHEEN = "Sheen JH, Sheen AP, Aesthetic Rhinoplasty, 2nd ed., Mosby, 1987"
_MARTIN = "Martin R, Saller K, Lehrbuch der Anthropologie, 3rd ed., Fischer, 1957"
_NAS = "naseview (3D geometry on the facial midline plane)"

_CLINICAL: list[MeasurementInfo] = [
    # ---- profile
    MeasurementInfo(
        "nasal_length", "mm", "nasal length: 3D distance nasion-pronasale (n-prn)",
        None, "", "Nasal length", "How long the nose is, from its root between the eyes "
        "to its tip.", ("n", "prn"), group="profile"),
    MeasurementInfo(
        "nasal_height", "mm", "nasal height: 3D distance nasion-subnasale (n-sn)",
        (44.0, 61.0), _FARKAS, "Nasal height", "How tall the nose is, from its root to "
        "where it meets the upper lip.", ("n", "sn"), group="profile"),
    MeasurementInfo(
        "nasofrontal_angle", "deg", "nasofrontal angle: angle at n between the line n-g and "
        "the dorsal tangent from n (the line from n touching the dorsum, on the midline "
        "profile)", (115.0, 130.0), _POWELL, "Nasofrontal angle",
        "The angle between the forehead and the bridge of the nose, seen from the side.",
        ("g", "n", "prn", "mesh"), group="profile"),
    MeasurementInfo(
        "dorsal_hump_depth", "mm", "dorsal hump depth: largest height of the midline "
        "profile between n and prn above the straight line n-prn, perpendicular to it; 0 "
        "for a straight or concave dorsum (the aesthetic female dorsum lies about 2 mm "
        "behind that line, the male on it or slightly in front)", None, _SHEEN,
        "Dorsal hump", "How far the bridge of the nose bulges above a straight line from "
        "its root to its tip.", ("n", "prn", "mesh"), group="profile"),
    MeasurementInfo(
        "radix_height", "mm", "radix height: anterior projection of n in front of the "
        "medial orbital rims (mean of mf_l, mf_r) along the facial anterior axis; no "
        "established norm for this reference", None, _MOWLAVI, "Radix height",
        "How far the root of the nose, between the eyes, stands out from the face.",
        ("n", "mf_l", "mf_r"), group="profile"),
    MeasurementInfo(
        "radix_level", "mm", "radix level: vertical position of n relative to the mean of "
        "mf_l, mf_r (+ above); no established norm for this reference (clinically the "
        "radix sits between the upper lash line and the supratarsal fold)", None, _MOWLAVI,
        "Radix level", "How high the root of the nose starts, compared with the inner "
        "corners of the eye sockets.", ("n", "mf_l", "mf_r"), group="profile"),
    MeasurementInfo(
        "nasolabial_angle", "deg", "nasolabial angle: angle at sn between the columella "
        "tangent (line fitted to the profile c-sn) and the upper-lip tangent (line fitted "
        "to the first 8 mm of profile below sn); needs the mesh", (90.0, 120.0), _ARMIJO,
        "Nasolabial angle", "The angle between the underside of the nose and the upper "
        "lip, seen from the side.", ("c", "sn", "mesh"),
        normal_female=(95.5, 100.1), normal_male=(93.4, 98.5), group="profile"),
    # ---- tip
    MeasurementInfo(
        "tip_rotation", "deg", "tip rotation: columellar-facial angle between the columella "
        "tangent (line fitted to the profile c-sn, directed forwards) and the downward "
        "facial vertical; 90 = horizontal columella, +1 per degree of upward rotation; no "
        "established norm", None, _AHMED, "Tip rotation", "How much the tip of the nose "
        "points up or down.", ("c", "sn", "mesh"), group="tip"),
    MeasurementInfo(
        "tip_projection", "mm", "tip projection (Goode): distance of prn in front of the "
        "alar line, the facial vertical through the alar crease (mean of ac_l, ac_r), in "
        "the lateral projection", None, _GOODE, "Tip projection (Goode)",
        "How far the tip of the nose stands out from the cheek.", ("prn", "ac_l", "ac_r"),
        group="tip"),
    MeasurementInfo(
        "goode_ratio", "", "Goode ratio: tip_projection / nasal length n-prn (lateral "
        "projection); the range is the aesthetic ideal", (0.55, 0.60), _GOODE,
        "Goode ratio", "How far the tip stands out compared with the length of the nose.",
        ("n", "prn", "ac_l", "ac_r"), group="tip"),
    MeasurementInfo(
        "crumley_projection", "mm", "Crumley tip projection: distance of prn from the line "
        "n-ac (ac = mean of ac_l, ac_r), the perpendicular through the tip of the "
        "triangle n, ac, prn (lateral projection); no norm in mm", None, _CRUMLEY,
        "Tip projection (Crumley)", "How far the tip stands out from a line joining the "
        "root of the nose and the nostril crease.", ("n", "prn", "ac_l", "ac_r"),
        group="tip"),
    MeasurementInfo(
        "crumley_ratio", "", "Crumley projection ratio: crumley_projection / nasal length "
        "n-prn; ideal 0.6 (the 3:4:5 triangle: projection 3, height 4, length 5); no "
        "range", None, _CRUMLEY, "Crumley projection ratio",
        "How far the tip stands out compared with the length of the nose, by a second "
        "method.", ("n", "prn", "ac_l", "ac_r"), group="tip"),
    MeasurementInfo(
        "crumley_height_ratio", "", "Crumley height ratio: distance from n to the foot of "
        "the tip's perpendicular on n-ac / nasal length n-prn; ideal 0.8 (3:4:5); no range",
        None, _CRUMLEY, "Crumley height ratio", "How tall the nose is compared with its "
        "length.", ("n", "prn", "ac_l", "ac_r"), group="tip"),
    MeasurementInfo(
        "columellar_show", "mm", "columellar show: vertical gap, in the lateral "
        "projection, between the alar rim (the lateral half of the nostril outline) and "
        "the columella's lower border (the mesh profile c-sn) at the middle of the "
        "columella (half-way from sn to c); mean of both sides; an approximation of "
        "Gunter's alar-columellar distance (2-4 mm in total)", (2.0, 4.0),
        _GUNTER, "Columellar show", "How much of the skin between the nostrils shows below "
        "the nostril rims, seen from the side.",
        ("c", "sn", "sill_l", "sill_r", "mesh"), group="tip"),
    MeasurementInfo(
        "tip_width", "mm", "tip width (domal distance): 3D distance between the dome "
        "points md_l-md_r, the tip-defining points of the lobule; no established norm in "
        "mm", None, "", "Tip width", "How wide the tip of the nose is, between its two "
        "highlights.", ("md_l", "md_r"), group="tip"),
    # ---- width
    MeasurementInfo(
        "nasal_width", "mm", "nasal width: 3D distance alare-alare (al_l-al_r); the "
        "calliper input when al_l-al_r was typed at intake", (27.0, 39.0), _FARKAS,
        "Nasal width", "How wide the nose is across the nostril wings.", ("al_l", "al_r"),
        group="width"),
    MeasurementInfo(
        "alar_base", "mm", "alar base width: 3D distance between the alar curvature points "
        "(ac_l-ac_r)", None, "", "Alar base width", "How wide the base of the nose is where "
        "the nostril wings join the cheeks.", ("ac_l", "ac_r"), group="width"),
    MeasurementInfo(
        "nasal_index", "", "nasal index: nasal_width / nasal_height x 100; a "
        "classification, not a norm: <70 leptorrhine, 70-85 mesorrhine, >85 platyrrhine",
        None, _MARTIN, "Nasal index", "How wide the nose is compared with its height.",
        ("al_l", "al_r", "n", "sn"), group="width"),
    MeasurementInfo(
        "intercanthal_width", "mm", "intercanthal width: distance between the inner eye "
        "corners en-en, estimated from the face model (medial corner of each eye opening "
        "of the mesh; en is not clicked); adult means are about 31-33 mm (approximate)",
        None, _FARKAS, "Intercanthal width (estimated)", "The distance between the inner "
        "corners of the eyes, estimated from the 3D face.", ("n", "mf_l", "mf_r", "mesh"),
        group="width"),
    MeasurementInfo(
        "alar_intercanthal_ratio", "", "alar / intercanthal ratio: nasal_width / "
        "intercanthal_width, the intercanthal width estimated from the face model; the "
        "orbitonasal canon says 1.0 (a guideline, valid in a minority of faces)", None,
        _CANON, "Alar / intercanthal ratio", "How wide the nose is compared with the gap "
        "between the eyes.", ("al_l", "al_r", "mesh"), group="width"),
    # ---- symmetry
    MeasurementInfo(
        "dorsal_deviation", "mm", "dorsal deviation: largest lateral offset of the dorsal "
        "ridge (apex of each horizontal mesh section, 15-85 % of the way n to prn) from "
        "the facial midline plane, signed + towards the subject's left; no established "
        "norm", None, _NAS, "Dorsal deviation", "How far the bridge of the nose leans to "
        "one side of the face's centre line.", ("n", "prn", "mf_l", "mf_r", "mesh"),
        group="symmetry"),
    MeasurementInfo(
        "tip_deviation", "mm", "tip deviation: lateral offset of prn from the facial "
        "midline plane, signed + towards the subject's left; no established norm", None,
        _NAS, "Tip deviation", "How far the tip of the nose sits to one side of the face's "
        "centre line.", ("prn", "g", "mf_l", "mf_r"), group="symmetry"),
    MeasurementInfo(
        "nostril_symmetry", "", "nostril symmetry: smaller / larger nostril area, the "
        "outlines sill_l, sill_r projected on their common base plane; 1 = symmetric; no "
        "established norm", None, _NAS, "Nostril symmetry", "How alike the two nostrils "
        "are in size, seen from below (1 means the same).", ("sill_l", "sill_r"),
        group="symmetry"),
]

_DISTANCES = [
    MeasurementInfo(distance_key(a, b), "mm", f"{a}-{b}: straight-line 3D distance "
                    f"{a}-{b} (paper Table 1)", None,
                    "Toan, Tuan, Thinh, CMES 2025, Table 1", f"{a}–{b}",
                    "A distance between two of the points marked on the photos.", (a, b),
                    group="distance")
    for a, b in TABLE1_DISTANCES
]

MEASUREMENT_INFO: dict[str, MeasurementInfo] = {m.name: m for m in (*_CLINICAL, *_DISTANCES)}
"""Every measurement :func:`clinical_measurements` can return, by name, in report order."""

def _aliases() -> dict[frozenset[str], tuple[str, ...]]:
    """Unordered landmark pair -> the names of that distance: its ``"a-b"`` key (Table 1
    order where it is a Table 1 distance) and the named measurement it is."""
    out: dict[frozenset[str], tuple[str, ...]] = {}
    for a, b in TABLE1_DISTANCES:
        out[frozenset((a, b))] = (distance_key(a, b),)
    for name, a, b in NAMED_DISTANCES:
        key = frozenset((a, b))
        out[key] = (*out.get(key, (distance_key(a, b),)), name)
    return out


_ALIASES = _aliases()
_IDS = frozenset(LANDMARK_IDS)


def calliper_inputs(scale_mm_keys: Iterable[str]) -> set[str]:
    """The measurement names whose value is fixed by a calliper distance typed at intake.

    The reconstruction is scaled so that the ``case.json`` ``scale_mm`` distances hold, so
    a measurement equal to one of them is the user's input, not a finding.

    Args:
        scale_mm_keys: keys ``"<id>-<id>"`` of ``scale_mm`` (either order).
    Returns:
        The distance's key and the named measurement it is: ``{"al_l-al_r",
        "nasal_width"}`` for ``["al_l-al_r"]`` or ``["al_r-al_l"]``; ``{"ac_l-ac_r",
        "alar_base"}`` for ``["ac_r-ac_l"]``; another pair of landmark ids gives its key
        as typed; anything else adds nothing.
    """
    out: set[str] = set()
    for key in scale_mm_keys:
        parts = str(key).split("-")
        if len(parts) != 2 or parts[0] == parts[1] or not set(parts) <= _IDS:
            continue
        out.update(_ALIASES.get(frozenset(parts), (str(key),)))
    return out


def format_measurements(values: Mapping[str, float],
                        estimated: Mapping[str, Estimate] | None = None) -> list[str]:
    """One human-readable line per measurement, in :data:`MEASUREMENT_INFO` order, with the
    typical range when one is known (for reports and the CLI). A measurement in
    ``estimated`` (:func:`~naseview.measurements.uncertainty.estimated_measurements`)
    carries its uncertainty and why: ``"... 10.20 mm ± 2.43 (estimated: mf seen in one
    photo)"``."""
    estimated = estimated or {}
    lines = []
    for name, info in MEASUREMENT_INFO.items():
        if name not in values:
            continue
        unit = {"deg": " deg", "mm": " mm"}.get(info.unit, "")
        rng = (f"  (typical {info.normal[0]:g}-{info.normal[1]:g}{unit})"
               if info.normal else "")
        est = estimated.get(name)
        sd = f" ± {est.sd_mm:.2f} (estimated: {est.reason})" if est is not None else ""
        lines.append(f"{name:24s} {values[name]:8.2f}{unit}{sd}{rng}")
    return lines
