"""File contents the app offers for download: landmarks and measurements.

Pure functions returning bytes (the page sends them with ``send_file_download``; the
same bytes can be written with :func:`naseview.fileio.atomic_write_bytes`). Coordinates
are in the SPEC frame (mm, origin g, +x subject's left, +y up, +z anterior). The mesh
files (GLB in metres, the others in mm, textured or watertight) are
:mod:`naseview.texture.mesh_files`', shared with ``naseview reconstruct --export``.
"""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Collection, Mapping
from typing import Any

import numpy as np

from naseview.landmarks import LANDMARKS
from naseview.measurements import MEASUREMENT_INFO, Estimate

FRAME = "SPEC: mm, origin glabella g, +x subject's left, +y up, +z anterior"


def _vec(p: np.ndarray) -> list[float]:
    return [float(x) for x in np.asarray(p, dtype=np.float64).reshape(3)]


def landmarks_json(current: Mapping[str, np.ndarray], original: Mapping[str, np.ndarray],
                   case_id: str = "") -> bytes:
    """JSON of the simulated and original landmark positions (mm) and each displacement."""
    obj: dict[str, Any] = {
        "format": "naseview.landmarks/1", "case": case_id, "units": "mm", "frame": FRAME,
        "landmarks": {k: _vec(v) for k, v in current.items()},
        "original": {k: _vec(v) for k, v in original.items()},
        "displacement_mm": {k: float(np.linalg.norm(np.asarray(current[k]) - original[k]))
                            for k in current if k in original},
    }
    return (json.dumps(obj, indent=1) + "\n").encode("utf-8")


def landmarks_csv(current: Mapping[str, np.ndarray],
                  original: Mapping[str, np.ndarray]) -> bytes:
    """CSV, one row per landmark: id, paper name, simulated x/y/z, original x/y/z,
    displacement (mm)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["id", "paper", "x_mm", "y_mm", "z_mm", "original_x_mm", "original_y_mm",
                "original_z_mm", "displacement_mm"])
    for k, p in current.items():
        o = original.get(k, p)
        w.writerow([k, LANDMARKS[k].paper if k in LANDMARKS else k,
                    *(f"{x:.4f}" for x in _vec(p)), *(f"{x:.4f}" for x in _vec(o)),
                    f"{np.linalg.norm(np.asarray(p) - np.asarray(o)):.4f}"])
    return buf.getvalue().encode("utf-8")


def _info(name: str) -> tuple[str, str, tuple[float, float] | None]:
    """(unit, description, typical range) of a measurement ("" / None when unknown)."""
    m = MEASUREMENT_INFO.get(name)
    if m is None:
        return "", "", None
    return m.unit, m.description, m.normal


def export_rows(original: Mapping[str, float], simulated: Mapping[str, float]
                ) -> list[tuple[str, str, float | None, float | None]]:
    """(name, unit, original, simulated) of every measurement in the exports: clinical
    measurements first, then the paper's landmark distances, then any other names (the
    report's table is :func:`naseview.report.measurement_rows`)."""
    known = [n for n in MEASUREMENT_INFO if n in original or n in simulated]
    names = [n for n in known if "-" not in n] + [n for n in known if "-" in n]
    names += [n for n in list(original) + list(simulated) if n not in names]
    seen: set[str] = set()
    rows: list[tuple[str, str, float | None, float | None]] = []
    for n in names:
        if n in seen:
            continue
        seen.add(n)
        rows.append((n, _info(n)[0], original.get(n), simulated.get(n)))
    return rows


def measurements_json(original: Mapping[str, float], simulated: Mapping[str, float],
                      case_id: str = "") -> bytes:
    """JSON: ``{name: {"unit", "original", "simulated", "change", "typical"}}``."""
    out: dict[str, Any] = {}
    for n, unit, o, s in export_rows(original, simulated):
        out[n] = {"unit": unit, "original": o, "simulated": s,
                  "change": None if o is None or s is None else s - o,
                  "typical": _info(n)[2], "description": _info(n)[1]}
    obj = {"format": "naseview.measurements/1", "case": case_id, "frame": FRAME,
           "measurements": out}
    return (json.dumps(obj, indent=1) + "\n").encode("utf-8")


def measurements_csv(original: Mapping[str, float], simulated: Mapping[str, float]) -> bytes:
    """CSV, one row per measurement: name, unit, original, simulated, change, typical."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["name", "unit", "original", "simulated", "change", "typical_low",
                "typical_high"])

    def f(x: float | None) -> str:
        return "" if x is None else f"{x:.4f}"

    for n, unit, o, s in export_rows(original, simulated):
        rng = _info(n)[2]
        w.writerow([n, unit, f(o), f(s), f(None if o is None or s is None else s - o),
                    f(rng[0] if rng else None), f(rng[1] if rng else None)])
    return buf.getvalue().encode("utf-8")


def measurements_markdown(original: Mapping[str, float],
                          simulated: Mapping[str, float], which: str = "all",
                          inputs: Collection[str] = (),
                          estimated: Mapping[str, Estimate] | None = None) -> str:
    """Markdown table ``| measurement | original | simulated | change |`` for the page;
    changes of at least 0.05 (mm, deg) are bold, values outside the typical range
    flagged with a dagger. ``which``: ``"clinical"`` (named measurements), ``"distances"``
    (the paper's landmark distances ``a-b``) or ``"all"``. ``inputs``: names whose value
    is a calliper distance typed at intake (:func:`naseview.measurements.calliper_inputs`):
    marked "input", never flagged against a range. ``estimated``: name ->
    :class:`~naseview.measurements.Estimate` (:func:`naseview.measurements.
    estimated_measurements`): shown ``10.2 ± 2.4`` and labelled ``*(estimated: mf seen
    in one photo)*``, never flagged (an input stays an input)."""
    estimated = estimated or {}
    lines = ["| measurement | orig. | sim. | change |", "|:--|--:|--:|--:|"]
    rows = export_rows(original, simulated)
    if which == "clinical":
        rows = [r for r in rows if "-" not in r[0]]
    elif which == "distances":
        rows = [r for r in rows if "-" in r[0]]
    for n, unit, o, s in rows:
        u = {"mm": "", "deg": "°"}.get(unit, "")
        rng = _info(n)[2]

        given = n in inputs
        est = None if given else estimated.get(n)
        pm = f" ± {est.sd_mm:.1f}" if est is not None else ""

        def fmt(x: float | None, rng: tuple[float, float] | None = rng, u: str = u,
                unit: str = unit, given: bool = given or est is not None,
                pm: str = pm) -> str:
            if x is None:
                return "–"
            flag = "†" if rng is not None and not given and not (rng[0] <= x <= rng[1]) \
                else ""
            return f"{x:.2f}{pm}{u}{flag}" if unit == "" else f"{x:.1f}{pm}{u}{flag}"

        if o is not None and s is not None:
            k = 2 if unit == "" else 1          # the change of the values as shown
            d = round(round(s, k) - round(o, k), k) + 0.0
            ch = f"{d:+.{k}f}"
            ch = f"**{ch}**" if abs(d) >= 0.05 else ch
        else:
            ch = "–"
        info = MEASUREMENT_INFO.get(n)
        label = (info.title if info is not None and info.title and "-" not in n
                 else n.replace("_", " ") if "-" not in n else n.replace("_", r"\_"))
        label += " *(input)*" if given else ""
        label += f" *(estimated: {est.reason})*" if est is not None else ""
        lines.append(f"| {label} | {fmt(o)} | {fmt(s)} | {ch} |")
    shown_est = [r[0] for r in rows if r[0] in estimated and r[0] not in inputs]
    if which != "distances":
        lines.append("")
        lines.append("mm unless marked; † outside the typical adult range"
                     + ("; *input*: the calliper distance typed at intake (the 3D result "
                        "is scaled to it), not a finding" if inputs else "")
                     + ("; *estimated*: ± one standard deviation from the depth "
                        "uncertainty of its landmarks; click them in a profile photo where "
                        "they show" if shown_est else "") + ".")
    return "\n".join(lines)
