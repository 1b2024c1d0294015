"""The report page: one self-contained HTML file (images embedded as base64 PNGs).

:func:`report_html` assembles the page from its sections (header and disclaimer, photos,
rendered views before / after, the measurements tables, notes, footer);
:func:`write_report` writes it, with the PNGs beside it, atomically. Nothing is fetched
from the network.
"""

from __future__ import annotations

import datetime as _dt
import html
import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from naseview import __version__
from naseview.errors import NaseviewError
from naseview.fileio import write_file_set
from naseview.landmarks import VIEWS
from naseview.report.data import DISCLAIMER, DISCLAIMER_DETAIL, ReportData
from naseview.report.images import (
    data_uri,
    fit,
    measurements_image,
    photos_sheet,
    png_bytes,
    views_sheet,
)
from naseview.report.table import MeasurementRow, format_range, format_value, measurement_rows
from naseview.report.views import RENDER_VIEWS, render_views

Images = dict[str, np.ndarray]
"""Name -> (H, W, 3) uint8 BGR image."""

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

_esc = html.escape


def _renders(data: ReportData, deidentified: bool, render_size: int
             ) -> tuple[Images, Images | None]:
    """Renders before and (with a simulation) after, sharing the "before" cameras; the
    "after" images carry the "before" silhouette; textured with the patient's skin when
    there is a texture, never in the de-identified version."""
    skin = None if deidentified else data.texture  # the patient's skin identifies them
    before, masks = render_views(data.V_before, data.F, data.nose_ids, render_size,
                                 nose_only=deidentified, texture=skin)
    after = None
    if data.V_after is not None:
        after, _ = render_views(data.V_after, data.F, data.nose_ids, render_size,
                                nose_only=deidentified, framing=data.V_before,
                                outline_of=masks, texture=skin)
    return before, after


def _header(data: ReportData, deidentified: bool) -> list[str]:
    """Document head, title, case line and the disclaimer box. The de-identified version
    names no case id and no date (nor anything else that could identify the patient)."""
    if deidentified:
        title = "naseview consultation report — de-identified"
        meta = "De-identified version: no photos, no case id, no date"
    else:
        date = data.date or _dt.date.today().isoformat()
        title = f"naseview consultation report — {_esc(data.case_id)}"
        meta = f"Case <b>{_esc(data.case_id)}</b> · {_esc(date)}"
    return ["<!DOCTYPE html>", "<html lang='en'><head><meta charset='utf-8'>",
            "<meta name='viewport' content='width=device-width, initial-scale=1'>",
            f"<title>{title}</title>",
            f"<style>{_CSS}</style></head><body>",
            "<h1>Nose consultation report</h1>",
            f"<div class='meta'>{meta}</div>",
            f"<div class='disclaimer'><strong>{_esc(DISCLAIMER)}</strong><br>"
            f"{_esc(DISCLAIMER_DETAIL)}</div>"]


def _photos_section(photos: Mapping[str, np.ndarray]) -> list[str]:
    """The photos, each at most 640 px, in SPEC view order."""
    parts = ["<h2>Photos</h2><div class='grid'>"]
    for v in VIEWS:
        if v in photos:
            parts.append(f"<figure><img alt='{v} photo' src='"
                         f"{data_uri(fit(photos[v], 640))}'>"
                         f"<figcaption>{_esc(v)}</figcaption></figure>")
    parts.append("</div>")
    return parts


def _views_section(before: Images, after: Images | None) -> list[str]:
    """The rendered views: one column per view, rows before and (if any) after."""
    title = "3D model: before and after the simulation" if after else "3D model"
    parts = [f"<h2>{title}</h2><table class='views'><tr>"]
    parts += [f"<th style='text-align:center'>{_esc(RENDER_VIEWS[v][0])}</th>"
              for v in RENDER_VIEWS]
    parts.append("</tr>")
    for label, imgs in (("before", before), ("after (simulation)", after)):
        if imgs is None:
            continue
        parts.append("<tr>")
        parts += [f"<td><img alt='{v} {label}' src='{data_uri(imgs[v])}'>"
                  f"<div class='meta'>{_esc(label)}</div></td>" for v in RENDER_VIEWS]
        parts.append("</tr>")
    parts.append("</table>")
    if after:
        parts.append("<p class='meta'>Blue outline on the simulation: the silhouette "
                     "before.</p>")
    return parts


def _cell(v: float | None, unit: str, flag: str) -> str:
    """A value cell, highlighted with its flag when outside the typical range."""
    cls = " class='out'" if flag else ""
    note = f" ({flag})" if flag else ""
    return f"<td{cls}>{_esc(format_value(v, unit))}{note}</td>"


def _row(r: MeasurementRow, after: bool) -> str:
    """One table row: title (with the definition for clinical ones), values, range."""
    desc = (f"<br><span class='desc'>{_esc(r['description'].split(':', 1)[-1].strip())}"
            "</span>" if r["group"] == "clinical" else "")
    return (f"<tr><td>{_esc(r['title'])}{desc}</td>"
            + _cell(r["before"], r["unit"], r["flag_before"])
            + ((_cell(r["after"], r["unit"], r["flag_after"])
                + "<td>" + _esc(format_value(r["change"], r["unit"], signed=True,
                                             ref=r["before"])) + "</td>")
               if after else "")
            + f"<td>{_esc(format_range(r['normal'], r['unit']))}</td></tr>")


_TABLE_TITLES = {"clinical": "Measurements", "table1": "Landmark distances (paper Table 1)"}


def _measurement_tables(rows: list[MeasurementRow], after: bool) -> list[str]:
    """One table per group of rows (clinical, then Table 1), and the note on ranges."""
    parts = []
    group = None
    for r in rows:
        if r["group"] != group:
            if group is not None:
                parts.append("</table>")
            group = r["group"]
            parts.append(f"<h2>{_TABLE_TITLES[group]}</h2><table><tr><th>Measurement</th>"
                         "<th>Before</th>" + ("<th>After</th><th>Change</th>" if after else "")
                         + "<th>Typical adult range</th></tr>")
        parts.append(_row(r, after))
    parts.append("</table><p class='meta'>Typical ranges are approximate adult norms "
                 "(they vary with sex and ancestry); a value outside them is not by itself "
                 "a finding.</p>")
    return parts


def _footer(credit: str) -> str:
    """Version, paper, face model credit and the disclaimer once more."""
    credit_text = f" Face model: {_esc(credit)}." if credit else ""
    return (f"<footer>Made with naseview {_esc(__version__)} (3D nose reconstruction from "
            "four photos and 21 landmarks after Toan, Tuan, Thinh, CMES 2025)." + credit_text
            + f" <b>{_esc(DISCLAIMER)}</b></footer></body></html>")


def report_html(data: ReportData, deidentified: bool = False, render_size: int = 480
                ) -> tuple[str, Images]:
    """The report page and its images.

    Args:
        data: what to show.
        deidentified: leave out photos and notes; render the nose region only.
        render_size: size of each rendered view (px).
    Returns:
        (HTML text, name -> BGR image of the PNGs that go with it: ``views``,
        ``measurements`` and, unless de-identified, ``photos``).
    """
    before, after = _renders(data, deidentified, render_size)
    rows = measurement_rows(data.measurements_before, data.measurements_after)
    images: Images = {"views": views_sheet(before, after),
                      "measurements": measurements_image(rows)}
    parts = _header(data, deidentified)
    if not deidentified and data.photos:
        images["photos"] = photos_sheet(data.photos)
        parts += _photos_section(data.photos)
    parts += _views_section(before, after)
    parts += _measurement_tables(rows, bool(after))
    if data.notes and not deidentified:
        parts.append(f"<h2>Notes</h2><p>{_esc(data.notes)}</p>")
    parts.append(_footer(data.credit))
    return "\n".join(parts), images


_PNG_PARTS = ("views", "measurements", "photos")
"""The PNGs a report may have beside its HTML, ``<stem>-<part>.png``."""


def write_report(data: ReportData, path: str | os.PathLike[str], deidentified: bool = False,
                 pngs: bool = True, render_size: int = 480) -> Path:
    """Write ``path`` (HTML) and, with ``pngs``, ``<stem>-views.png``,
    ``<stem>-measurements.png`` and ``<stem>-photos.png`` beside it, all or nothing
    (:func:`naseview.fileio.write_file_set`); PNGs of an earlier report of that name that
    this one does not have (the photos, for a de-identified report) are removed.

    Returns:
        the HTML path.
    Raises:
        NaseviewError: not an ``.html`` name, or the folder is not writable / the disk is
            full (an earlier report is then unchanged).
    """
    path = Path(path)
    if path.suffix.lower() not in (".html", ".htm"):
        raise NaseviewError(f"{path}: the report is an HTML file; give a name ending in "
                            ".html")
    text, images = report_html(data, deidentified, render_size)
    files = {f"{path.stem}-{name}.png": png_bytes(img)
             for name, img in images.items()} if pngs else {}
    files[path.name] = text.encode("utf-8")
    write_file_set(path.parent, files,
                   remove=[f"{path.stem}-{name}.png" for name in _PNG_PARTS])
    return path
