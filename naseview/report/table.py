"""The measurements of the report: plain-language rows for the patient, then the paper's
landmark distances for the technical appendix.

Values are :func:`naseview.measurements.clinical_measurements` of the reconstruction
(before) and of the simulation (after). Each clinical row carries the measurement's
title, a plain sentence for the patient and its usual adult range as text (``normal`` of
:data:`naseview.measurements.MEASUREMENT_INFO`, as in the app; by sex only when no overall
range is given); no row is flagged
against its range. A value the reconstruction was scaled to (a calliper distance typed
at intake, ``case.json`` ``scale_mm``) is marked ``calliper``: it is an input, not a
finding. A value whose uncertainty from its landmarks exceeds
:data:`~naseview.measurements.ESTIMATED_SD_MM` (radix height when mf is seen in the front
photo only, :func:`naseview.measurements.estimated_measurements`) carries its sd and is
shown as an estimate ("10.2 ± 2.4 mm", :func:`estimate_note`), never as a plain finding.
The landmark distances are the paper's Table 1
(:data:`naseview.landmarks.TABLE1_DISTANCES`), group ``"table1"``.

Example
-------
>>> rows = measurement_rows({"nasal_length": 47.0}, {"nasal_length": 45.5})
>>> rows[0]["title"], rows[0]["change"]
('Nasal length', -1.5)
>>> format_value(-1.5, "mm", signed=True)
'-1.5 mm'
>>> from types import SimpleNamespace
>>> usual_range_text(SimpleNamespace(unit="deg", normal=(115.0, 135.0)))
'usual range 115–135°'
>>> usual_range_text(SimpleNamespace(unit="deg", normal=None, normal_female=(95.0, 110.0),
...                                  normal_male=(90.0, 95.0)))
'women 95–110°, men 90–95°'
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Mapping
from typing import Any, TypedDict

from naseview import measurements as _measurements
from naseview.landmarks import TABLE1_DISTANCES
from naseview.measurements import MEASUREMENT_INFO, Estimate, distance_key

_calliper_inputs: Callable[[set[str]], Collection[str]] | None = getattr(
    _measurements, "calliper_inputs", None)
"""``naseview.measurements.calliper_inputs`` once it exists (same rule as the fallback)."""

_SCALE_NAMES = {"al_l-al_r": "nasal_width", "ac_l-ac_r": "alar_base"}
"""Named measurement equal to a calliper distance (fallback of ``calliper_inputs``)."""

_TITLES = {
    "nasal_length": "Nasal length", "nasal_height": "Nasal height",
    "nasal_width": "Nasal width", "alar_base": "Width of the nostril base",
    "nasal_index": "Width compared with height", "nasofrontal_angle": "Nasofrontal angle",
    "tip_projection": "Tip projection", "goode_ratio": "Tip projection ratio (Goode)",
    "dorsal_hump_depth": "Dorsal hump",
}
"""Titles of the clinical measurements until ``MeasurementInfo.title`` exists."""

_PLAIN = {
    "nasal_length": "Length of the nose from the top of the bridge (between the eyes) "
                    "to the tip.",
    "nasal_height": "Height of the nose from the top of the bridge to where it meets "
                    "the upper lip.",
    "nasal_width": "Width of the nose across the nostril wings.",
    "alar_base": "Width of the base of the nose, where the nostril wings meet the cheeks.",
    "nasal_index": "Width of the nose compared with its height (width divided by "
                   "height, times 100).",
    "nasofrontal_angle": "The angle between the forehead and the bridge of the nose, at "
                         "the top of the nose.",
    "tip_projection": "How far the tip stands out from the face, measured from the "
                      "crease of the nostril wing.",
    "goode_ratio": "How far the tip stands out compared with the length of the nose.",
    "dorsal_hump_depth": "How far the bridge of the nose rises above a straight line from "
                         "the top of the nose to the tip (0 means a straight bridge).",
}
"""Patient sentences of the clinical measurements until ``MeasurementInfo.plain`` exists."""


class MeasurementRow(TypedDict):
    """One row of the measurements table (units: ``"mm"``, ``"deg"`` or ``""``).

    ``group``: ``"clinical"`` or ``"table1"`` (the paper's landmark distances);
    ``section``: the clinical measurement's group in
    :data:`~naseview.measurements.MEASUREMENT_INFO` (``"profile"``, ``"tip"``, ...; ""
    when not given); ``title``: the measurement's name ("Nasal length"; "mf_l–mf_r" for
    a landmark distance); ``plain``: a sentence for the patient ("" for a landmark distance);
    ``usual``: its usual adult range as text ("usual range 115–135°", "women 95–110°,
    men 90–95°", or "" when there is none); ``calliper``: the value before is a calliper
    distance typed at intake (an input, not a finding); ``sd``: the value's standard
    deviation (mm) when it is an estimate, else None; ``estimated``: why, for the surgeon
    ("mf seen in one photo"; "" when not an estimate); ``estimate_note``: the same for
    the patient ("" when not an estimate).
    """

    name: str
    title: str
    plain: str
    group: str
    section: str
    description: str
    unit: str
    before: float
    after: float | None
    change: float | None
    normal: tuple[float, float] | None
    usual: str
    calliper: bool
    sd: float | None
    estimated: str
    estimate_note: str


def calliper_names(scale_keys: Collection[str]) -> set[str]:
    """Measurement names whose value is a calliper input, for the case's ``scale_mm``
    keys (``{"al_l-al_r"}`` -> ``{"al_l-al_r", "nasal_width"}``):
    :func:`naseview.measurements.calliper_inputs` when it exists, else the keys plus the
    named measurement equal to each (``nasal_width``, ``alar_base``)."""
    keys = {str(k) for k in scale_keys}
    if _calliper_inputs is not None:
        return set(_calliper_inputs(keys))
    return keys | {_SCALE_NAMES[k] for k in keys if k in _SCALE_NAMES}


def _range(value: Any) -> tuple[float, float] | None:
    """A ``(low, high)`` range attribute, or None."""
    if isinstance(value, (tuple, list)) and len(value) == 2:
        return float(value[0]), float(value[1])
    return None


def usual_range_text(info: Any) -> str:
    """The usual adult range of a :class:`~naseview.measurements.MeasurementInfo` as the
    patient reads it: ``"usual range 115–135°"`` (``normal``, the range the app's table
    and the exports show: one source for all three), else ``"women 95–110°, men
    90–95°"`` when it has only ranges by sex (``normal_female`` / ``normal_male``), else
    ``""``."""
    unit = str(getattr(info, "unit", ""))
    normal = _range(getattr(info, "normal", None))
    if normal:
        return f"usual range {format_range(normal, unit)}"
    by_sex = [(who, _range(getattr(info, attr, None)))
              for who, attr in (("women", "normal_female"), ("men", "normal_male"))]
    return ", ".join(f"{who} {format_range(r, unit)}" for who, r in by_sex if r)


def _title(name: str, info: Any) -> str:
    """``info.title``, else :data:`_TITLES`, else the description's head, capitalised."""
    title = str(getattr(info, "title", "") or _TITLES.get(name, "")
                or info.description.split(":", 1)[0].strip() or name)
    return title[:1].upper() + title[1:]


_PATIENT_POINTS = {"mf": "the inner corners of the eye sockets",
                   "n": "the root of the nose between the eyes",
                   "g": "the brow between the eyebrows"}
"""How a patient reads the landmarks an estimate can come from."""


def estimate_note(est: Estimate, unit: str = "mm") -> str:
    """What the patient reads under an estimated value: ``"Estimated: the inner corners
    of the eye sockets show in one photo only, so this value may be off by about 2.4 mm
    either way."``"""
    u = {"mm": " mm", "deg": "°"}.get(unit, "")
    what = " and ".join(_PATIENT_POINTS.get(p, "a point marked on the photos")
                        for p in est.points) or "the points it is measured from"
    why = "show in one photo only" if est.one_photo else "are hard to place in the photos"
    return (f"Estimated: {what} {why}, so this value may be off by about "
            f"{est.sd_mm:.1f}{u} either way.")


def format_estimate(v: float | None, sd: float | None, unit: str) -> str:
    """A value with its uncertainty when it has one: ``"10.2 ± 2.4 mm"``
    (:func:`format_value` otherwise)."""
    if v is None or sd is None:
        return format_value(v, unit)
    u = {"mm": " mm", "deg": "°"}.get(unit, "")
    return f"{v:.1f} ± {sd:.1f}{u}"


def measurement_rows(before: Mapping[str, float], after: Mapping[str, float] | None = None,
                     scale_keys: Collection[str] = (),
                     estimated: Mapping[str, Estimate] | None = None) -> list[MeasurementRow]:
    """Rows of the measurements table: clinical measurements first, then the paper's
    Table 1 landmark distances, each group in :data:`MEASUREMENT_INFO` order.

    Args:
        before: name -> value of the reconstruction.
        after: name -> value after the simulation, or None.
        scale_keys: the case's calliper distances (``scale_mm`` keys): their rows get
            ``calliper`` True (:func:`calliper_names`).
        estimated: name -> :class:`~naseview.measurements.Estimate` of the
            reconstruction (:func:`naseview.measurements.estimated_measurements`): their
            rows get ``sd``, ``estimated`` and ``estimate_note`` (a calliper input never
            does).
    Returns:
        :class:`MeasurementRow` dicts (``change`` = after - before, or None).
    """
    table1 = {distance_key(a, b) for a, b in TABLE1_DISTANCES}
    calliper = calliper_names(scale_keys)
    estimated = estimated or {}
    rows: list[MeasurementRow] = []
    for name, info in MEASUREMENT_INFO.items():
        if name not in before:
            continue
        b = float(before[name])
        a = float(after[name]) if after is not None and name in after else None
        group = "table1" if name in table1 else "clinical"
        clinical = group == "clinical"
        est = None if name in calliper else estimated.get(name)
        rows.append({
            "name": name, "group": group, "description": info.description,
            "section": str(getattr(info, "group", "") or "") if clinical else "",
            "title": _title(name, info) if clinical else name.replace("-", "–"),
            "plain": str(getattr(info, "plain", "") or _PLAIN.get(name, ""))
            if clinical else "",
            "unit": info.unit, "before": b, "after": a,
            "change": None if a is None else a - b, "normal": _range(info.normal),
            "usual": usual_range_text(info), "calliper": name in calliper,
            "sd": None if est is None else float(est.sd_mm),
            "estimated": "" if est is None else est.reason,
            "estimate_note": "" if est is None else estimate_note(est, info.unit)})
    rows.sort(key=lambda r: r["group"] != "clinical")   # stable: keeps the info order
    return rows


def _digits(unit: str, mag: float) -> int:
    """Decimals a value is shown with: 2 for a ratio below 5, else 1."""
    return 2 if unit == "" and abs(mag) < 5 else 1


def format_value(v: float | None, unit: str, signed: bool = False,
                 ref: float | None = None) -> str:
    """A value with its unit; ratios below 5 (by ``ref``, default the value) get 2
    decimals, everything else 1."""
    if v is None:
        return "—"
    digits = _digits(unit, v if ref is None else ref)
    s = f"{v:+.{digits}f}" if signed else f"{v:.{digits}f}"
    return s + {"mm": " mm", "deg": "°"}.get(unit, "")


def format_range(normal: tuple[float, float] | None, unit: str) -> str:
    """``"40–55 mm"``: a range with its unit (``"—"`` without one)."""
    if normal is None:
        return "—"
    u = {"mm": " mm", "deg": "°"}.get(unit, "")
    if unit == "" and max(abs(normal[0]), abs(normal[1])) < 5:
        return f"{normal[0]:.2f}–{normal[1]:.2f}"
    return f"{normal[0]:g}–{normal[1]:g}{u}"


def format_change(before: float | None, after: float | None, unit: str) -> str:
    """The change as the reader checks it against the shown values: after minus before,
    each rounded as :func:`format_value` shows it (``-1.36 -> -1.33`` shows ``-1.4``,
    ``-1.3`` and ``+0.1``, never ``+0.0``); ``"—"`` without both."""
    if before is None or after is None:
        return "—"
    d_b, d_a = _digits(unit, before), _digits(unit, after)
    d = max(d_b, d_a)
    change = round(round(after, d_a) - round(before, d_b), d) + 0.0
    return format_value(change, unit, signed=True, ref=before if d == d_b else after)
