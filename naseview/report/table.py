"""The measurements table of the report: clinical measurements, then the paper's Table 1.

Values are :func:`naseview.measurements.clinical_measurements` of the reconstruction
(before) and of the simulation (after), flagged against the typical adult ranges of
:data:`naseview.measurements.MEASUREMENT_INFO`; the landmark distances are the paper's
Table 1 (:data:`naseview.landmarks.TABLE1_DISTANCES`).

Example
-------
>>> rows = measurement_rows({"nasal_length": 47.0}, {"nasal_length": 45.5})
>>> rows[0]["title"], rows[0]["change"]
('nasal length', -1.5)
>>> format_value(-1.5, "mm", signed=True)
'-1.5 mm'
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TypedDict

from naseview.landmarks import TABLE1_DISTANCES
from naseview.measurements import MEASUREMENT_INFO, distance_key


class MeasurementRow(TypedDict):
    """One row of the measurements table (units: ``"mm"``, ``"deg"`` or ``""``)."""

    name: str
    title: str
    group: str
    description: str
    unit: str
    before: float
    after: float | None
    change: float | None
    normal: tuple[float, float] | None
    flag_before: str
    flag_after: str


def _flag(v: float | None, normal: tuple[float, float] | None) -> str:
    """``"low"``, ``"high"`` or ``""`` of ``v`` against the range ``normal``."""
    if v is None or normal is None:
        return ""
    return "low" if v < normal[0] else "high" if v > normal[1] else ""


def measurement_rows(before: Mapping[str, float], after: Mapping[str, float] | None = None
                     ) -> list[MeasurementRow]:
    """Rows of the measurements table: clinical measurements first, then the paper's
    Table 1 landmark distances, each group in :data:`MEASUREMENT_INFO` order.

    Each row: ``name``, ``title`` (e.g. "nasal length", "mf_l–mf_r"), ``group``
    (``"clinical"`` or ``"table1"``), ``description``, ``unit``, ``before``, ``after``
    (or None), ``change`` (or None), ``normal`` ((low, high) or None) and ``flag_before`` /
    ``flag_after`` (``"low"``, ``"high"`` or ``""`` against the typical range).
    """
    table1 = {distance_key(a, b) for a, b in TABLE1_DISTANCES}
    rows: list[MeasurementRow] = []
    for name, info in MEASUREMENT_INFO.items():
        if name not in before:
            continue
        b = float(before[name])
        a = float(after[name]) if after is not None and name in after else None
        group = "table1" if name in table1 else "clinical"
        title = (name.replace("-", "–") if group == "table1"
                 else info.description.split(":", 1)[0].strip() or name)
        rows.append({"name": name, "title": title, "group": group,
                     "description": info.description, "unit": info.unit,
                     "before": b, "after": a, "change": None if a is None else a - b,
                     "normal": info.normal, "flag_before": _flag(b, info.normal),
                     "flag_after": _flag(a, info.normal)})
    rows.sort(key=lambda r: r["group"] != "clinical")   # stable: keeps the info order
    return rows


def format_value(v: float | None, unit: str, signed: bool = False,
                 ref: float | None = None) -> str:
    """A value with its unit; ratios below 5 (by ``ref``, default the value) get 3
    decimals, everything else 1."""
    if v is None:
        return "—"
    mag = abs(v if ref is None else ref)
    digits = 3 if unit == "" and mag < 5 else 1
    s = f"{v:+.{digits}f}" if signed else f"{v:.{digits}f}"
    return s + {"mm": " mm", "deg": "°"}.get(unit, "")


def format_range(normal: tuple[float, float] | None, unit: str) -> str:
    """``"40–55 mm"``: a typical range with its unit (``"—"`` without one)."""
    if normal is None:
        return "—"
    u = {"mm": " mm", "deg": "°"}.get(unit, "")
    return f"{normal[0]:g}–{normal[1]:g}{u}"
