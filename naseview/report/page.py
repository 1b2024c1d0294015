"""The report page: one self-contained HTML file (images embedded as base64 PNGs).

:func:`report_html` assembles the page from its sections (header and disclaimer, the
plan, the measurements in plain language, photos, before / after pairs, notes, the
technical appendix, footer), styled to print on A4 (``@page``; each before / after pair
on one page);
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
from naseview.measurements import MEASUREMENT_INFO
from naseview.report.data import (
    ACCURACY_STATEMENT,
    DISCLAIMER,
    DISCLAIMER_DETAIL,
    ReportData,
    surgeon_notes,
)
from naseview.report.images import (
    data_uri,
    fit,
    measurements_image,
    photos_sheet,
    png_bytes,
    views_sheet,
)
from naseview.report.plan import plan_figures, plan_sentences
from naseview.report.table import (
    MeasurementRow,
    format_change,
    format_estimate,
    measurement_rows,
)
from naseview.report.views import OUTLINE_VIEWS, RENDER_VIEWS, render_views

Images = dict[str, np.ndarray]
"""Name -> (H, W, 3) uint8 BGR image."""

_CSS = """
@page{size:A4;margin:14mm 14mm 14mm 14mm}
body{font-family:system-ui,-apple-system,'Segoe UI',Roboto,Arial,sans-serif;margin:24px auto;
color:#222;max-width:900px;padding:0 16px;line-height:1.4}
h1{font-size:24px;margin:0 0 4px}
h2{font-size:18px;margin:24px 0 8px;border-bottom:1px solid #ddd;padding-bottom:4px}
.meta{color:#666;font-size:13px}
.calm{border:1px solid #bbb;border-radius:6px;padding:10px 14px;margin:16px 0;
font-size:14px}
.calm strong{font-size:16px}
table{border-collapse:collapse;width:100%;font-size:14px}
th,td{padding:5px 8px;border-bottom:1px solid #eee;text-align:right;vertical-align:top}
th{font-weight:600;white-space:nowrap}
td.v{white-space:nowrap}
th:first-child,td:first-child{text-align:left}
.plain{display:block;color:#555;font-size:12.5px}
.usual{color:#888;font-size:12.5px}
.hint{display:block;color:#888;font-size:11.5px;white-space:normal}
.plan li{margin:2px 0}
td.what{width:46%}
tr{break-inside:avoid;page-break-inside:avoid}
tr.sec th{text-align:left;font-size:12.5px;color:#444;background:#f6f6f6}
td.usual{width:20%}
.photos .grid{display:flex;flex-wrap:wrap;gap:10px}
.photos figure{margin:0;flex:1 1 40%}
.photos img{width:100%;max-height:110mm;object-fit:contain;border:1px solid #ddd;
border-radius:4px}
.pair{break-inside:avoid;page-break-inside:avoid}
.duo{display:flex;gap:12px}
.duo figure{margin:0;flex:1 1 0}
.duo img{width:100%;border:1px solid #ddd;border-radius:4px}
figcaption{font-size:13px;color:#555;text-align:center}
.appendix{font-size:11px;color:#444}
.appendix h2{font-size:14px}
.appendix table{font-size:11px}
footer{margin-top:24px;color:#777;font-size:11px}
@media print{
body{margin:0;padding:0;max-width:none;font-size:10.5pt}
.photos,.pair,.appendix{break-before:page;page-break-before:always}
.duo img{width:87mm;height:87mm}
body{line-height:1.28}
h1{font-size:18pt}
h2{font-size:12.5pt;margin:12px 0 5px}
table{font-size:9.5pt}
th,td{padding:2px 5px}
td.usual{white-space:nowrap}
.plain,.usual{font-size:8.5pt}
.hint{font-size:8pt}
.meta{font-size:8.5pt}
.calm{font-size:10pt;margin:10px 0}
.photos img{max-height:100mm}
}
"""
"""Screen and print styles: A4 pages; the photos, each before/after pair and the
technical appendix start a new printed page, and a pair never breaks across pages."""

_esc = html.escape


def _renders(data: ReportData, deidentified: bool, render_size: int
             ) -> tuple[Images, Images | None]:
    """Renders before and (with a simulation) after, sharing the "before" cameras; the
    "after" profile carries the "before" silhouette; textured with the patient's skin when
    there is a texture, never in the de-identified version (clean grey nose renders)."""
    skin = None if deidentified else data.texture  # the patient's skin identifies them
    before, masks = render_views(data.V_before, data.F, data.nose_ids, render_size,
                                 nose_only=deidentified, texture=skin,
                                 framing=data.V_before if deidentified else None)
    after = None
    if data.V_after is not None:
        after, _ = render_views(data.V_after, data.F, data.nose_ids, render_size,
                                nose_only=deidentified, framing=data.V_before,
                                outline_of={v: masks[v] for v in OUTLINE_VIEWS},
                                texture=skin)
    return before, after


def _title(data: ReportData, deidentified: bool) -> str:
    """The document title: the patient's name, else the case id (full version only)."""
    if deidentified:
        return "Nose consultation report (de-identified)"
    who = data.patient_name.strip() or data.case_id.strip()
    return f"Nose consultation report — {who}" if who else "Nose consultation report"


def _header(data: ReportData, deidentified: bool) -> list[str]:
    """Document head, title, who / when, and the calm disclaimer note. The de-identified
    version names no patient, case id, date, surgeon or clinic."""
    title = _esc(_title(data, deidentified))
    if deidentified:
        meta = ["De-identified version: no photos, no names, no dates."]
    else:
        date = data.date or _dt.date.today().isoformat()
        meta = [f"Date: {_esc(date)}"]
        if data.patient_name.strip() and data.case_id.strip():
            meta.append(f"Case: {_esc(data.case_id)}")
        meta += [f"{label}: {_esc(v.strip())}" for label, v in
                 (("Surgeon", data.surgeon), ("Clinic", data.clinic)) if v.strip()]
    return ["<!DOCTYPE html>", "<html lang='en'><head><meta charset='utf-8'>",
            "<meta name='viewport' content='width=device-width, initial-scale=1'>",
            f"<title>{title}</title>",
            f"<style>{_CSS}</style></head><body>",
            f"<h1>{title}</h1>",
            f"<div class='meta'>{' · '.join(meta)}</div>",
            f"<div class='calm'><strong>{_esc(DISCLAIMER)}</strong><br>"
            f"{_esc(DISCLAIMER_DETAIL)}</div>"]


def _plan_section(amounts: Mapping[str, float]) -> list[str]:
    """The planned manoeuvres: one patient sentence each, with the surgeon's term and
    the amount in grey."""
    sentences = plan_sentences(amounts)
    if not sentences:
        return []
    figures = plan_figures(amounts)
    parts = ["<section class='plan'><h2>What is planned</h2><ul>"]
    for k, t in enumerate(sentences):
        term = (f" <span class='usual'>({_esc(figures[k][0])}, {_esc(figures[k][1])})"
                "</span>" if len(figures) == len(sentences) else "")
        parts.append(f"<li>{_esc(t)}{term}</li>")
    parts.append("</ul></section>")
    return parts


def _cell(v: float | None, unit: str, sd: float | None = None) -> str:
    """A value cell (``"10.2 ± 2.4 mm"`` when it is an estimate with sd ``sd``)."""
    return f"<td class='v'>{_esc(format_estimate(v, sd, unit))}</td>"


CALLIPER_NOTE = "Measured with a calliper at your visit (not calculated from the photos)."
"""What a row whose value is a calliper input says instead of presenting a finding."""


def _row(r: MeasurementRow, after: bool) -> str:
    """One patient row: title and plain sentence, before (after, change), usual range."""
    plain = f"<span class='plain'>{_esc(r['plain'])}</span>" if r["plain"] else ""
    if r["calliper"]:
        plain += f"<span class='hint'>{_esc(CALLIPER_NOTE)}</span>"
    if r["estimate_note"]:
        plain += f"<span class='hint'>{_esc(r['estimate_note'])}</span>"
    usual = _esc(r["usual"]).replace(" mm", "&nbsp;mm") if r["usual"] else "—"
    cells = _cell(r["before"], r["unit"], r["sd"])
    if after:
        cells += (_cell(r["after"], r["unit"], r["sd"]) + "<td class='v'>"
                  + _esc(format_change(r["before"], r["after"], r["unit"]))
                  + "</td>")
    return (f"<tr><td class='what'><b>{_esc(r['title'])}</b>{plain}</td>{cells}"
            f"<td class='usual'>{usual}</td></tr>")


_SECTIONS = {"profile": "The nose seen from the side", "tip": "The tip of the nose",
             "width": "The width of the nose", "symmetry": "Symmetry"}
"""Patient headings of the measurement groups (others: the group name, capitalised)."""


def _measurements_section(rows: list[MeasurementRow], after: bool) -> list[str]:
    """The patient's measurements table (a heading row per group when the measurements
    have groups), what the usual ranges mean, and the accuracy statement."""
    clinical = [r for r in rows if r["group"] == "clinical"]
    if not clinical:
        return []
    ncol = 5 if after else 3
    parts = ["<section class='measurements'><h2>Your measurements</h2><table><thead><tr>"
             "<th>What is measured</th><th>Before</th>"
             + ("<th>After</th><th>Change</th>" if after else "")
             + "<th>Usual adult range</th></tr></thead><tbody>"]
    section = ""
    for r in clinical:
        if r["section"] and r["section"] != section:
            section = r["section"]
            head = _SECTIONS.get(section, section.replace("_", " ").capitalize())
            parts.append(f"<tr class='sec'><th colspan='{ncol}'>{_esc(head)}</th></tr>")
        parts.append(_row(r, after))
    parts.append("</tbody></table><p class='meta'>Usual ranges are approximate figures "
                 "for adults; they differ between women and men and between populations. "
                 "Many people are outside them, and that alone is not a problem.</p>"
                 f"<p class='meta'>{_esc(ACCURACY_STATEMENT)}</p></section>")
    return parts


def _photos_section(photos: Mapping[str, np.ndarray]) -> list[str]:
    """The photos, each at most 640 px, in SPEC view order."""
    parts = ["<section class='photos'><h2>Your photos</h2><div class='grid'>"]
    for v in VIEWS:
        if v in photos:
            parts.append(f"<figure><img alt='{v} photo' src='"
                         f"{data_uri(fit(photos[v], 640))}'>"
                         f"<figcaption>{_esc(v)}</figcaption></figure>")
    parts.append("</div></section>")
    return parts


OUTLINE_SENTENCE = "The blue line on the simulation shows the profile before."
"""Under the profile pair only (:data:`~naseview.report.views.OUTLINE_VIEWS`)."""


def _pairs_section(before: Images, after: Images | None) -> list[str]:
    """One block per view: before and (if any) after side by side, one printed page."""
    parts = []
    for v, (title, _) in RENDER_VIEWS.items():
        head = f"{title}: before and after" if after else f"{title}"
        parts.append(f"<section class='pair' id='pair-{v}'><h2>{_esc(head)}</h2>"
                     "<div class='duo'>")
        for label, imgs in (("Before", before), ("After (simulation)", after)):
            if imgs is not None:
                parts.append(f"<figure><img alt='{v} {label.lower()}' "
                             f"src='{data_uri(imgs[v])}'>"
                             f"<figcaption>{_esc(label)}</figcaption></figure>")
        parts.append("</div>")
        if after and v in OUTLINE_VIEWS:
            parts.append(f"<p class='meta'>{_esc(OUTLINE_SENTENCE)}</p>")
        parts.append("</section>")
    return parts


def _appendix(rows: list[MeasurementRow], after: bool) -> list[str]:
    """Small print for the surgeon: the paper's landmark distances and the definitions
    and sources of the measurements."""
    table1 = [r for r in rows if r["group"] == "table1"]
    clinical = [r for r in rows if r["group"] == "clinical"]
    if not table1 and not clinical:
        return []
    parts = ["<section class='appendix'><h2>Technical appendix for your surgeon</h2>"]
    if table1:
        parts.append("<p>Landmark distances (straight 3D distances, mm; Toan, Tuan, "
                     "Thinh, CMES 2025, Table 1):</p><table><tr><th>Landmarks</th>"
                     "<th>Before</th>" + ("<th>After</th><th>Change</th>" if after else "")
                     + "</tr>")
        for r in table1:
            parts.append(f"<tr><td>{_esc(r['title'])}</td>"
                         + _cell(r["before"], r["unit"])
                         + ((_cell(r["after"], r["unit"]) + "<td class='v'>"
                             + _esc(format_change(r["before"], r["after"], r["unit"]))
                             + "</td>") if after else "") + "</tr>")
        parts.append("</table>")
    if clinical:
        parts.append("<p>Definitions and sources of the ranges:</p><ul>")
        for r in clinical:
            src = MEASUREMENT_INFO[r["name"]].source
            parts.append(f"<li><b>{_esc(r['title'])}</b>: {_esc(r['description'])}."
                         + (f" Range: {_esc(src)}." if src else "")
                         + (" Calliper input of this case (the scale)." if r["calliper"]
                            else "")
                         + (f" Estimated ({_esc(r['estimated'])}): ± {r['sd']:.1f} mm is "
                            "one standard deviation, from the stated depth uncertainty "
                            "of its landmarks (docs/measurements.md)."
                            if r["sd"] is not None else "") + "</li>")
        parts.append("</ul>")
    parts.append("</section>")
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

    Page order: title, who and when, the disclaimer note; the plan; the measurements
    with their usual ranges and the accuracy statement (printed page 1); the photos
    (page 2); one page per view with before and after side by side; notes from the
    surgeon; the technical appendix (the paper's landmark distances, definitions,
    sources; last page); footer.

    Args:
        data: what to show.
        deidentified: leave out photos, notes, names, ids, dates, surgeon, clinic and
            the technical appendix (the 11 landmark distances are a fine-grained
            measurement of one face); clean grey nose renders, never the skin.
        render_size: size of each rendered view (px).
    Returns:
        (HTML text, name -> BGR image of the PNGs that go with it: ``views``,
        ``measurements`` and, unless de-identified, ``photos``).
    """
    before, after = _renders(data, deidentified, render_size)
    rows = measurement_rows(data.measurements_before, data.measurements_after,
                            tuple(data.calliper), data.estimated)
    images: Images = {"views": views_sheet(before, after),
                      "measurements": measurements_image(rows)}
    has_after = bool(after)
    parts = _header(data, deidentified)
    parts += _plan_section(data.manoeuvres)
    parts += _measurements_section(rows, has_after)
    if not deidentified and data.photos:
        images["photos"] = photos_sheet(data.photos)
        parts += _photos_section(data.photos)
    parts += _pairs_section(before, after)
    notes = "" if deidentified else surgeon_notes(data.notes)
    if notes:
        parts.append(f"<section class='notes'><h2>Notes from your surgeon</h2>"
                     f"<p>{_esc(notes)}</p></section>")
    if not deidentified:
        parts += _appendix(rows, has_after)
    parts.append(_footer(data.credit))
    return "\n".join(parts), images


PNG_PARTS = ("views", "measurements", "photos")
"""The PNGs a report may have beside its HTML, ``<stem>-<part>.png``."""


def write_report(data: ReportData, path: str | os.PathLike[str], deidentified: bool = False,
                 pngs: bool = True, render_size: int = 480, overwrite: bool = True) -> Path:
    """Write ``path`` (HTML) and, with ``pngs``, ``<stem>-views.png``,
    ``<stem>-measurements.png`` and ``<stem>-photos.png`` beside it, all or nothing
    (:func:`naseview.fileio.write_file_set`); PNGs of an earlier report of that name that
    this one does not have (the photos, for a de-identified report) are removed. With
    ``overwrite`` False an existing HTML or PNG of that name is refused (nothing written).

    Returns:
        the HTML path.
    Raises:
        NaseviewError: not an ``.html`` name, the folder is not writable / the disk is
            full, or (``overwrite`` False) the report exists (an earlier report is then
            unchanged).
    """
    path = Path(path)
    if path.suffix.lower() not in (".html", ".htm"):
        raise NaseviewError(f"{path}: the report is an HTML file; give a name ending in "
                            ".html")
    text, images = report_html(data, deidentified, render_size)
    files = {f"{path.stem}-{name}.png": png_bytes(img)
             for name, img in images.items()} if pngs else {}
    files[path.name] = text.encode("utf-8")
    write_file_set(path.parent, files, overwrite=overwrite,
                   remove=[f"{path.stem}-{name}.png" for name in PNG_PARTS]
                   if overwrite else [])
    return path
