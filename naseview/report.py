"""Consultation report: one self-contained HTML page plus PNG images.

The report shows the four photos, rendered views of the nose before and after the
simulation (front, profile, three-quarter, bottom; :func:`naseview.render.render_mesh`),
the clinical measurements with their typical adult ranges
(:data:`naseview.measurements.MEASUREMENT_INFO`) and, prominently, the line
:data:`DISCLAIMER`. Every image is embedded as a base64 PNG, so the HTML file can be
mailed or archived on its own; nothing is fetched from the network.

The de-identified version leaves out the photos and the free-text notes and renders the
nose region only (no eyes, no face outline).

Example
-------
>>> data = report_data_from_session("session.json")          # doctest: +SKIP
>>> write_report(data, "out/report.html")                    # doctest: +SKIP
PosixPath('out/report.html')
"""

from __future__ import annotations

import argparse
import base64
import datetime as _dt
import html
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from naseview.camera import Camera, look_at
from naseview.errors import NaseviewError
from naseview.fileio import atomic_write_bytes

DISCLAIMER = "A simulation is not a promised outcome."
"""The sentence every report carries (also in the de-identified version)."""

DISCLAIMER_DETAIL = (
    "The images after the simulation show a geometric deformation of a 3D model built "
    "from four photos; healing, skin thickness and cartilage behave differently in every "
    "patient. Measurements are estimates from photos, typically within about 1 mm.")

RENDER_VIEWS: dict[str, tuple[str, tuple[float, float, float]]] = {
    "front": ("Front", (0.0, 0.0, 1.0)),
    "profile": ("Profile (right)", (-1.0, 0.0, 0.0)),
    "three_quarter": ("Three-quarter (right)", (-math.sin(math.radians(45.0)), 0.0,
                                               math.cos(math.radians(45.0)))),
    "bottom": ("Bottom (basal)", (0.0, -math.sin(math.radians(60.0)),
                                  math.cos(math.radians(60.0)))),
}
"""Rendered views: name -> (title, direction from the nose towards the camera, SPEC
frame: +x subject's left, +y up, +z anterior)."""

PHOTO_VIEWS = ("front", "left", "right", "bottom")
SKIN_BGR = (168, 192, 226)
NOSE_ONLY_BGR = (150, 172, 222)
OUTLINE_BGR = (200, 110, 30)
"""Blue outline of the silhouette before the simulation, drawn on the "after" renders."""


@dataclass
class ReportData:
    """What a report shows (SPEC frame, mm).

    Attributes:
        case_id: anonymised id.
        V_before: (N, 3) face mesh of the reconstruction.
        F: (M, 3) triangles.
        nose_ids: (K,) vertices of the nose region.
        measurements_before: name -> value of the reconstruction.
        V_after: (N, 3) simulated mesh, or ``None`` (no simulation: "before" only).
        measurements_after: name -> value after the simulation, or ``None``.
        photos: view -> (H, W, 3) uint8 BGR photo (may be empty).
        notes: free text (left out of the de-identified version).
        credit: face model credit line.
        date: date shown in the header (default today).
    """

    case_id: str
    V_before: np.ndarray
    F: np.ndarray
    nose_ids: np.ndarray
    measurements_before: dict[str, float]
    V_after: np.ndarray | None = None
    measurements_after: dict[str, float] | None = None
    photos: dict[str, np.ndarray] = field(default_factory=dict)
    notes: str = ""
    credit: str = ""
    date: str = ""


# ----------------------------------------------------------------------------- rendering
def view_camera(V: np.ndarray, nose_ids: np.ndarray, view: str, size: int = 480,
                field_factor: float = 2.3) -> Camera:
    """Camera looking at the nose from ``view`` (:data:`RENDER_VIEWS`).

    Args:
        V: (N, 3) mesh (mm).
        nose_ids: (K,) nose-region vertices (centre and extent of the framing).
        view: key of :data:`RENDER_VIEWS`.
        size: image width = height (px).
        field_factor: field of view width as a multiple of the nose extent.
    Returns:
        a :class:`~naseview.camera.Camera` 600 mm away (a portrait-lens perspective).
    """
    P = V[nose_ids] if len(nose_ids) else V
    centre = 0.5 * (P.min(axis=0) + P.max(axis=0))
    extent = float(np.ptp(P, axis=0).max()) if len(P) else 60.0
    if view == "bottom":  # aim at the nasal base, not at the middle of the dorsum
        low = P[P[:, 1] <= np.quantile(P[:, 1], 0.4)]
        centre = 0.5 * (low.min(axis=0) + low.max(axis=0))
    direction = np.asarray(RENDER_VIEWS[view][1], dtype=np.float64)
    direction /= np.linalg.norm(direction)
    dist = 600.0
    focal = size * dist / max(field_factor * extent, 1.0)
    up = (0.0, 1.0, 0.0)
    return look_at(centre + dist * direction, centre, up, focal, size, size)


def cap_holes(V: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Close the inner holes of an open face mesh (eyes, mouth) with triangle fans.

    Every boundary loop but the longest (the outline of the face) gets a vertex at its
    centroid and one triangle per loop edge, oriented like the mesh. A face model with
    open eyes then renders with closed lids instead of see-through holes.

    Args:
        V: (N, 3) vertices; F: (M, 3) triangles.
    Returns:
        (N + H, 3) vertices and (M + sum of loop lengths, 3) triangles.
    """
    from naseview.facemodel.meshcurves import region_boundary_loops

    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    loops = region_boundary_loops(F, np.arange(len(V)))[1:]
    if not loops:
        return V, F
    extra_V, extra_F = [], []
    for loop in loops:
        c = len(V) + len(extra_V)
        extra_V.append(V[loop].mean(axis=0))
        a, b = loop, np.roll(loop, -1)
        extra_F.append(np.column_stack([b, a, np.full(len(loop), c)]))
    return np.vstack([V, np.array(extra_V)]), np.vstack([F, *extra_F])


def render_views(V: np.ndarray, F: np.ndarray, nose_ids: np.ndarray, size: int = 480,
                 nose_only: bool = False, framing: np.ndarray | None = None,
                 outline_of: Mapping[str, np.ndarray] | None = None
                 ) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """Shaded renders of a face (or nose-only) mesh from every :data:`RENDER_VIEWS` view.

    Args:
        V: (N, 3) vertices (mm).
        F: (M, 3) triangles.
        nose_ids: (K,) nose region.
        size: image size (px).
        nose_only: render only the triangles whose three vertices are in the region;
            otherwise eye and mouth holes are closed (:func:`cap_holes`).
        framing: (N, 3) vertices that fix the cameras (so before and after share them);
            default ``V``.
        outline_of: view -> (size, size) bool silhouette to draw as a blue outline
            (the "before" silhouette on the "after" images).
    Returns:
        view -> (size, size, 3) uint8 BGR, and view -> (size, size) bool silhouette.
    """
    import cv2

    from naseview.render import render_mesh

    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    nose_ids = np.asarray(nose_ids, dtype=np.int64)
    frame_V = V if framing is None else np.asarray(framing, dtype=np.float64)
    if nose_only and len(nose_ids):
        inside = np.zeros(len(V), dtype=bool)
        inside[nose_ids] = True
        F = F[inside[F].all(axis=1)]
    else:
        V, F = cap_holes(V, F)
    colors = np.tile(np.asarray(NOSE_ONLY_BGR if nose_only else SKIN_BGR, np.uint8),
                     (len(V), 1))
    images, masks = {}, {}
    for view in RENDER_VIEWS:
        cam = view_camera(frame_V, nose_ids, view, size, 1.5 if nose_only else 1.9)
        res = render_mesh(V, F, cam, vertex_colors=colors, supersample=2,
                          background=(255, 255, 255))
        img = res.image.copy()
        masks[view] = np.isfinite(res.depth)
        if outline_of is not None and view in outline_of:
            cs, _ = cv2.findContours(outline_of[view].astype(np.uint8),
                                     cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
            layer = np.zeros(img.shape[:2], np.uint8)
            cv2.drawContours(layer, cs, -1, 255, 2, cv2.LINE_AA)
            layer[:3], layer[-3:], layer[:, :3], layer[:, -3:] = 0, 0, 0, 0  # not the frame
            a = (layer.astype(np.float32) / 255.0)[:, :, None]
            img = (img * (1 - a) + np.asarray(OUTLINE_BGR, np.float32) * a).astype(np.uint8)
        images[view] = img
    return images, masks


# ----------------------------------------------------------------------------- tables
def measurement_rows(before: Mapping[str, float], after: Mapping[str, float] | None = None
                     ) -> list[dict[str, Any]]:
    """Rows of the measurements table: clinical measurements first, then the paper's
    Table 1 landmark distances, each group in :data:`MEASUREMENT_INFO` order.

    Each row: ``name``, ``title`` (e.g. "nasal length", "mf_l–mf_r"), ``group``
    (``"clinical"`` or ``"table1"``), ``description``, ``unit``, ``before``, ``after``
    (or None), ``change`` (or None), ``normal`` ((low, high) or None) and ``flag_before`` /
    ``flag_after`` (``"low"``, ``"high"`` or ``""`` against the typical range).
    """
    from naseview.landmarks import TABLE1_DISTANCES
    from naseview.measurements import MEASUREMENT_INFO, distance_key

    table1 = {distance_key(a, b) for a, b in TABLE1_DISTANCES}

    def flag(v: float | None, normal: tuple[float, float] | None) -> str:
        if v is None or normal is None:
            return ""
        return "low" if v < normal[0] else "high" if v > normal[1] else ""

    rows = []
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
                     "normal": info.normal, "flag_before": flag(b, info.normal),
                     "flag_after": flag(a, info.normal)})
    rows.sort(key=lambda r: r["group"] != "clinical")   # stable: keeps the info order
    return rows


def _fmt(v: float | None, unit: str, signed: bool = False, ref: float | None = None) -> str:
    """A value with its unit; ratios below 5 (by ``ref``, default the value) get 3
    decimals, everything else 1."""
    if v is None:
        return "—"
    mag = abs(v if ref is None else ref)
    digits = 3 if unit == "" and mag < 5 else 1
    s = f"{v:+.{digits}f}" if signed else f"{v:.{digits}f}"
    return s + {"mm": " mm", "deg": "°"}.get(unit, "")


def _range(normal: tuple[float, float] | None, unit: str) -> str:
    if normal is None:
        return "—"
    u = {"mm": " mm", "deg": "°"}.get(unit, "")
    return f"{normal[0]:g}–{normal[1]:g}{u}"


# ----------------------------------------------------------------------------- images
def png_bytes(image_bgr: np.ndarray) -> bytes:
    """PNG encoding of an (H, W, 3) uint8 BGR image (no metadata)."""
    import cv2

    ok, buf = cv2.imencode(".png", image_bgr)
    if not ok:
        raise NaseviewError("could not encode a report image as PNG")
    return buf.tobytes()


def _data_uri(image_bgr: np.ndarray) -> str:
    return "data:image/png;base64," + base64.b64encode(png_bytes(image_bgr)).decode("ascii")


def _fit(image_bgr: np.ndarray, max_side: int) -> np.ndarray:
    import cv2

    h, w = image_bgr.shape[:2]
    s = max_side / float(max(h, w))
    if s >= 1.0:
        return image_bgr
    return cv2.resize(image_bgr, (max(1, round(w * s)), max(1, round(h * s))),
                      interpolation=cv2.INTER_AREA)


def _label(img: np.ndarray, text: str) -> np.ndarray:
    import cv2

    out = img.copy()
    cv2.putText(out, text, (10, 26), cv2.FONT_HERSHEY_SIMPLEX, 0.7, (60, 60, 60), 2,
                cv2.LINE_AA)
    return out


def views_sheet(before: Mapping[str, np.ndarray], after: Mapping[str, np.ndarray] | None
                ) -> np.ndarray:
    """A grid PNG: one column per view, rows "before" and (if given) "after"."""
    rows = [np.hstack([_label(before[v], f"{RENDER_VIEWS[v][0]} - before")
                       for v in RENDER_VIEWS])]
    if after:
        rows.append(np.hstack([_label(after[v], f"{RENDER_VIEWS[v][0]} - after")
                               for v in RENDER_VIEWS]))
    return np.vstack(rows)


def photos_sheet(photos: Mapping[str, np.ndarray], height: int = 360) -> np.ndarray:
    """The photos side by side at a common height (BGR)."""
    import cv2

    tiles = []
    for v in PHOTO_VIEWS:
        if v not in photos:
            continue
        p = photos[v]
        s = height / float(p.shape[0])
        tiles.append(_label(cv2.resize(p, (max(1, round(p.shape[1] * s)), height),
                                       interpolation=cv2.INTER_AREA), v))
    if not tiles:
        return np.full((height, height, 3), 255, np.uint8)
    return np.hstack(tiles)


def measurements_image(rows: list[dict[str, Any]], width: int = 900) -> np.ndarray:
    """The measurements table drawn as an image (BGR), for the PNG output."""
    import cv2

    line = 30
    h = line * (len(rows) + 3) + 10
    img = np.full((h, width, 3), 255, np.uint8)
    font = cv2.FONT_HERSHEY_SIMPLEX
    cols = (10, 300, 440, 580, 720)
    heads = ("measurement", "before", "after", "change", "typical")
    for x, t in zip(cols, heads, strict=True):
        cv2.putText(img, t, (x, line), font, 0.6, (0, 0, 0), 2, cv2.LINE_AA)
    for k, r in enumerate(rows):
        y = line * (k + 2)
        if k % 2 == 0:
            cv2.rectangle(img, (0, y - line + 8), (width, y + 8), (245, 245, 245), -1)
        vals = (r["title"], _fmt(r["before"], r["unit"]), _fmt(r["after"], r["unit"]),
                _fmt(r["change"], r["unit"], signed=True, ref=r["before"]),
                _range(r["normal"], r["unit"]))
        for j, (x, t) in enumerate(zip(cols, vals, strict=True)):
            t = t.replace("°", " deg").replace("—", "-").replace("–", "-")
            colour = (0, 0, 0)
            if (j == 1 and r["flag_before"]) or (j == 2 and r["flag_after"]):
                colour = (0, 90, 200)
            cv2.putText(img, t, (x, y), font, 0.55, colour, 1, cv2.LINE_AA)
    cv2.putText(img, DISCLAIMER, (10, h - 14), font, 0.6, (0, 0, 160), 2, cv2.LINE_AA)
    return img


# ----------------------------------------------------------------------------- HTML
_CSS = """
body{font-family:system-ui,-apple-system,'Segoe UI',Roboto,Arial,sans-serif;margin:24px;
color:#222;max-width:1100px}
h1{font-size:24px;margin:0 0 4px}h2{font-size:18px;margin:28px 0 8px;
border-bottom:1px solid #ddd;padding-bottom:4px}
.meta{color:#666;font-size:13px}
.disclaimer{background:#fff4e5;border-left:5px solid #e67e22;padding:10px 14px;
margin:16px 0;font-size:15px}
.disclaimer strong{font-size:17px}
.grid{display:flex;flex-wrap:wrap;gap:10px}
.grid figure{margin:0;flex:1 1 230px;max-width:260px}
.grid img{width:100%;border:1px solid #ddd;border-radius:4px}
figcaption{font-size:12px;color:#555;text-align:center}
table{border-collapse:collapse;width:100%;font-size:14px}
th,td{padding:5px 8px;border-bottom:1px solid #eee;text-align:right;white-space:nowrap}
td:first-child{white-space:normal}
th:first-child,td:first-child{text-align:left}
td.desc{color:#666;font-size:12px;text-align:left}
.out{color:#b35900;font-weight:600}
.views td{text-align:center;vertical-align:top}
.views img{width:100%;max-width:260px;border:1px solid #ddd;border-radius:4px}
footer{margin-top:30px;color:#777;font-size:12px}
@media print{body{margin:8mm}.grid figure{max-width:180px}}
"""


def report_html(data: ReportData, deidentified: bool = False, render_size: int = 480
                ) -> tuple[str, dict[str, np.ndarray]]:
    """The report page and its images.

    Args:
        data: what to show.
        deidentified: leave out photos and notes; render the nose region only.
        render_size: size of each rendered view (px).
    Returns:
        (HTML text, name -> BGR image of the PNGs that go with it: ``views``,
        ``measurements`` and, unless de-identified, ``photos``).
    """
    from naseview import __version__

    before, masks = render_views(data.V_before, data.F, data.nose_ids, render_size,
                                 nose_only=deidentified)
    after = None
    if data.V_after is not None:
        after, _ = render_views(data.V_after, data.F, data.nose_ids, render_size,
                                nose_only=deidentified, framing=data.V_before,
                                outline_of=masks)
    rows = measurement_rows(data.measurements_before, data.measurements_after)
    images: dict[str, np.ndarray] = {"views": views_sheet(before, after),
                                     "measurements": measurements_image(rows)}
    esc = html.escape
    date = data.date or _dt.date.today().isoformat()
    parts = ["<!DOCTYPE html>", "<html lang='en'><head><meta charset='utf-8'>",
             "<meta name='viewport' content='width=device-width, initial-scale=1'>",
             f"<title>naseview consultation report — {esc(data.case_id)}</title>",
             f"<style>{_CSS}</style></head><body>",
             "<h1>Nose consultation report</h1>",
             f"<div class='meta'>Case <b>{esc(data.case_id)}</b> · {esc(date)}"
             + (" · de-identified version (no photos)" if deidentified else "") + "</div>",
             f"<div class='disclaimer'><strong>{esc(DISCLAIMER)}</strong><br>"
             f"{esc(DISCLAIMER_DETAIL)}</div>"]
    if not deidentified and data.photos:
        images["photos"] = photos_sheet(data.photos)
        parts.append("<h2>Photos</h2><div class='grid'>")
        for v in PHOTO_VIEWS:
            if v in data.photos:
                parts.append(f"<figure><img alt='{v} photo' src='"
                             f"{_data_uri(_fit(data.photos[v], 640))}'>"
                             f"<figcaption>{esc(v)}</figcaption></figure>")
        parts.append("</div>")
    title = "3D model: before and after the simulation" if after else "3D model"
    parts.append(f"<h2>{title}</h2><table class='views'><tr>")
    parts += [f"<th style='text-align:center'>{esc(RENDER_VIEWS[v][0])}</th>"
              for v in RENDER_VIEWS]
    parts.append("</tr>")
    for label, imgs in (("before", before), ("after (simulation)", after)):
        if imgs is None:
            continue
        parts.append("<tr>")
        parts += [f"<td><img alt='{v} {label}' src='{_data_uri(imgs[v])}'>"
                  f"<div class='meta'>{esc(label)}</div></td>" for v in RENDER_VIEWS]
        parts.append("</tr>")
    parts.append("</table>")
    if after:
        parts.append("<p class='meta'>Blue outline on the simulation: the silhouette "
                     "before.</p>")
    def cell(v: float | None, unit: str, flag: str) -> str:
        cls = " class='out'" if flag else ""
        note = f" ({flag})" if flag else ""
        return f"<td{cls}>{esc(_fmt(v, unit))}{note}</td>"

    heads = {"clinical": "Measurements", "table1": "Landmark distances (paper Table 1)"}
    group = None
    for r in rows:
        if r["group"] != group:
            if group is not None:
                parts.append("</table>")
            group = r["group"]
            parts.append(f"<h2>{heads[group]}</h2><table><tr><th>Measurement</th>"
                         "<th>Before</th>" + ("<th>After</th><th>Change</th>" if after else "")
                         + "<th>Typical adult range</th></tr>")
        desc = (f"<br><span class='desc'>{esc(r['description'].split(':', 1)[-1].strip())}"
                "</span>" if r["group"] == "clinical" else "")
        parts.append(f"<tr><td>{esc(r['title'])}{desc}</td>"
                     + cell(r["before"], r["unit"], r["flag_before"])
                     + ((cell(r["after"], r["unit"], r["flag_after"])
                         + "<td>" + esc(_fmt(r["change"], r["unit"], signed=True,
                                             ref=r["before"])) + "</td>")
                        if after else "")
                     + f"<td>{esc(_range(r['normal'], r['unit']))}</td></tr>")
    parts.append("</table><p class='meta'>Typical ranges are approximate adult norms "
                 "(they vary with sex and ancestry); a value outside them is not by itself "
                 "a finding.</p>")
    if data.notes and not deidentified:
        parts.append(f"<h2>Notes</h2><p>{esc(data.notes)}</p>")
    credit = f" Face model: {esc(data.credit)}." if data.credit else ""
    parts.append(
        f"<footer>Made with naseview {esc(__version__)} (3D nose reconstruction from four "
        "photos and 21 landmarks after Toan, Tuan, Thinh, CMES 2025)." + credit
        + f" <b>{esc(DISCLAIMER)}</b></footer></body></html>")
    return "\n".join(parts), images


def write_report(data: ReportData, path: str | os.PathLike[str], deidentified: bool = False,
                 pngs: bool = True, render_size: int = 480) -> Path:
    """Write ``path`` (HTML) and, with ``pngs``, ``<stem>-views.png``,
    ``<stem>-measurements.png`` and ``<stem>-photos.png`` beside it; all atomically.

    Returns:
        the HTML path.
    """
    path = Path(path)
    if path.suffix.lower() not in (".html", ".htm"):
        raise NaseviewError(f"{path}: the report is an HTML file; give a name ending in "
                            ".html")
    text, images = report_html(data, deidentified, render_size)
    if pngs:
        for name, img in images.items():
            atomic_write_bytes(path.with_name(f"{path.stem}-{name}.png"), png_bytes(img))
    return atomic_write_bytes(path, text.encode("utf-8"))


# ----------------------------------------------------------------------------- loading
def _photos_of(case_dir: Any) -> dict[str, np.ndarray]:
    from naseview.case import read_case

    if not case_dir:
        return {}
    try:
        case = read_case(Path(case_dir))
    except NaseviewError:
        return {}
    return {v: case.load_image(v) for v in case.views}


def report_data_from_session(path: str | os.PathLike[str], case_dir: Any = None
                             ) -> ReportData:
    """A :class:`ReportData` from a ``naseview.session/1`` file (before = its baseline,
    after = its saved simulation when it has one); photos from ``case_dir`` or the case
    directory the session names."""
    from naseview.editing.state import load_session

    s = load_session(path)
    b = s.baseline
    sim = s.simulation
    edited = sim is not None and not np.array_equal(sim.V, b.V)
    return ReportData(
        case_id=str(s.app.get("case_id", Path(path).stem)), V_before=b.V, F=b.F,
        nose_ids=b.nose_ids, measurements_before=dict(b.measurements),
        V_after=sim.V if edited and sim is not None else None,
        measurements_after=dict(sim.measurements) if edited and sim is not None else None,
        photos=_photos_of(case_dir or s.app.get("case_dir")),
        credit=str(s.app.get("credit", "")))


def report_data_from_output(out_dir: str | os.PathLike[str], case_dir: Any = None
                            ) -> ReportData:
    """A "before only" :class:`ReportData` from ``naseview reconstruct`` output."""
    from naseview.editing.baseline import baseline_from_output_dir

    out = Path(out_dir)
    b = baseline_from_output_dir(out)
    rec = b.reconstruction
    cdir = case_dir or (rec.extra.get("case_dir") if rec else None) or (
        out if (out / "case.json").is_file() else None)
    return ReportData(case_id=out.name, V_before=b.V, F=b.F, nose_ids=b.nose_ids,
                      measurements_before=dict(b.measurements), photos=_photos_of(cdir),
                      credit=str(rec.extra.get("credit", "")) if rec else "")


def report_command(args: argparse.Namespace) -> int:
    """``naseview report PATH [-o OUT.html] [--deidentified] [--case CASE_DIR]``."""
    path = Path(args.path)
    if path.is_file():
        data = report_data_from_session(path, getattr(args, "case", None))
    elif (path / "reconstruction.json").is_file():
        data = report_data_from_output(path, getattr(args, "case", None))
    else:
        raise NaseviewError(f"{path}: expected a session file (saved from the app) or a "
                            "`naseview reconstruct` output directory")
    out = Path(args.output) if getattr(args, "output", None) else (
        (path.parent if path.is_file() else path)
        / f"report{'-deidentified' if args.deidentified else ''}.html")
    written = write_report(data, out, deidentified=bool(args.deidentified))
    print(written)
    return 0


__all__ = ["DISCLAIMER", "RENDER_VIEWS", "ReportData", "measurement_rows", "render_views",
           "report_command", "report_data_from_output", "report_data_from_session",
           "report_html", "view_camera", "write_report"]
