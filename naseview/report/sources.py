"""Where a report's data comes from: a session file or ``naseview reconstruct`` output,
and the ``naseview report`` command."""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from naseview import reconstruction as _reconstruction
from naseview.case import read_case
from naseview.editing.baseline import Baseline, baseline_from_output_dir
from naseview.editing.session import load_session
from naseview.errors import NaseviewError
from naseview.fileio import current_set_file
from naseview.measurements import Estimate, estimated_measurements
from naseview.reconstruction import RECONSTRUCTION_FILE, Reconstruction, output_case_dir
from naseview.report.data import ReportData, surgeon_notes
from naseview.report.page import PNG_PARTS as REPORT_PNG_PARTS
from naseview.report.page import write_report
from naseview.report.pdf import write_report_pdf
from naseview.texture.bake import FaceTexture, skin_texture

CaseDir = str | os.PathLike[str] | None
"""A case directory (SPEC §3) to take the photos from, or None (no photos)."""


@dataclass
class _CaseFacts:
    """What a report takes from the case folder: its id, the surgeon's notes (machine
    text dropped, :func:`~naseview.report.data.surgeon_notes`), the calliper distances
    (``"<id>-<id>"`` -> mm) and the photos (view -> (H, W, 3) uint8 BGR)."""

    case_id: str = ""
    notes: str = ""
    calliper: dict[str, float] = field(default_factory=dict)
    photos: dict[str, np.ndarray] = field(default_factory=dict)


def _facts_of(case_dir: CaseDir, photos: bool = True) -> _CaseFacts:
    """The :class:`_CaseFacts` of a case folder (empty without one); photos only when
    ``photos``.

    Raises:
        NaseviewError: the case folder cannot be read (its own one-line error).
    """
    if not case_dir:
        return _CaseFacts()
    case = read_case(Path(case_dir))
    return _CaseFacts(str(case.id), surgeon_notes(case.notes),
                      {f"{a}-{b}": float(d) for (a, b), d in case.scale_mm.items()},
                      {v: case.load_image(v) for v in case.views} if photos else {})


def _stored_facts(find: Callable[[], Path | None], where: Path, photos: bool
                  ) -> _CaseFacts:
    """The facts of the case folder a session or output folder names (``find``). For a
    report with photos, an error names the fix; without photos (de-identified) a folder
    that is refused or unreadable is simply not used (the report needs none of it)."""
    try:
        return _facts_of(find(), photos)
    except NaseviewError as e:
        if not photos:
            return _CaseFacts()
        raise NaseviewError(f"{e} (photos named by {where}; pass --case CASE_DIR, or "
                            "--deidentified for a report without photos)") from None


def _facts(case_dir: CaseDir, find: Callable[[], Path | None], where: Path,
           photos: bool) -> _CaseFacts:
    """The facts of ``case_dir`` when given (errors raised as they are), else of the
    stored case folder (:func:`_stored_facts`)."""
    return _facts_of(case_dir, photos) if case_dir else _stored_facts(find, where, photos)


def _calliper(rec: Reconstruction | None, facts: _CaseFacts) -> dict[str, float]:
    """The calliper distances echoed in ``reconstruction.json``
    (:func:`naseview.reconstruction.calliper_distances`), else the case's."""
    echo = getattr(_reconstruction, "calliper_distances", None)
    found = dict(echo(rec)) if rec is not None and echo is not None else {}
    return found or dict(facts.calliper)


def _estimated(rec: Reconstruction | None) -> dict[str, Estimate]:
    """The reconstruction's measurements to show as estimates
    (:func:`naseview.measurements.estimated_measurements`; none without a record)."""
    return estimated_measurements(rec.landmarks, rec.extra) if rec is not None else {}


def report_data_from_session(path: str | os.PathLike[str], case_dir: CaseDir = None,
                             photos: bool = True) -> ReportData:
    """A :class:`ReportData` from a ``naseview.session/1`` file (before = its baseline,
    after = its saved simulation when it has one, the plan = its manoeuvres); the case id
    (the app's, else ``case.json``'s), notes, calliper keys and photos (unless ``photos``
    is False) from ``case_dir`` or the case folder the session names
    (:meth:`~naseview.editing.session.Session.case_folder`: inside the session file's
    folder only).

    Raises:
        NaseviewError: a bad session file, or a case folder that is refused or unreadable.
    """
    s = load_session(path)
    b = s.baseline
    sim = s.simulation
    edited = sim is not None and not np.array_equal(sim.V, b.V)
    facts = _facts(case_dir, s.case_folder, Path(path), photos)
    return ReportData(
        case_id=str(s.app.get("case_id") or facts.case_id), V_before=b.V, F=b.F,
        nose_ids=b.nose_ids, measurements_before=dict(b.measurements),
        V_after=sim.V if edited and sim is not None else None,
        measurements_after=dict(sim.measurements) if edited and sim is not None else None,
        photos=facts.photos, notes=facts.notes, credit=str(s.app.get("credit", "")),
        texture=_skin(b, facts.photos),
        manoeuvres={str(k): float(v) for k, v in getattr(s, "manoeuvres", {}).items()},
        calliper=_calliper(getattr(b, "reconstruction", None), facts),
        estimated=_estimated(getattr(b, "reconstruction", None)))


def report_data_from_output(out_dir: str | os.PathLike[str], case_dir: CaseDir = None,
                            photos: bool = True) -> ReportData:
    """A "before only" :class:`ReportData` from ``naseview reconstruct`` output; the
    case id, notes, calliper keys and photos (unless ``photos`` is False) from
    ``case_dir``, the case folder the output names
    (:func:`~naseview.reconstruction.output_case_dir`) or the output folder itself when
    it holds ``case.json``. The case id is ``case.json``'s, never the output folder's
    name."""
    out = Path(out_dir)
    b = baseline_from_output_dir(out)
    rec = b.reconstruction

    def stored() -> Path | None:
        return output_case_dir(out, rec) or (out if (out / "case.json").is_file() else None)

    facts = _facts(case_dir, stored, out / RECONSTRUCTION_FILE, photos)
    return ReportData(case_id=facts.case_id, V_before=b.V, F=b.F, nose_ids=b.nose_ids,
                      measurements_before=dict(b.measurements), photos=facts.photos,
                      notes=facts.notes, credit=_credit_of(rec),
                      texture=_skin(b, facts.photos), calliper=_calliper(rec, facts),
                      estimated=_estimated(rec))


def _skin(baseline: Baseline, photos: dict[str, np.ndarray]) -> FaceTexture | None:
    """The patient's skin for the report's renders, baked from the photos with the
    reconstruction's cameras (None without photos)."""
    rec = baseline.reconstruction
    return skin_texture(baseline.V, baseline.F, rec.cameras, photos) if rec else None


def _credit_of(rec: Reconstruction | None) -> str:
    """The face model's credit line recorded by stage 3 (``mesh.credit``), or ""."""
    mesh = rec.extra.get("mesh") if rec is not None else None
    return str(mesh.get("credit", "")) if isinstance(mesh, dict) else ""


def free_report_name(folder: Path, stem: str) -> Path:
    """``folder/<stem>.html``, else ``<stem>-2.html``, ``-3``... : the first name with no
    HTML or PNG of an earlier report (``naseview report`` never overwrites one)."""
    for k in range(1, 1000):
        name = stem if k == 1 else f"{stem}-{k}"
        parts = [f"{name}.html", f"{name}.pdf",
                 *(f"{name}-{p}.png" for p in REPORT_PNG_PARTS)]
        if not any(os.path.lexists(folder / p) for p in parts):
            return folder / f"{name}.html"
    raise NaseviewError(f"{folder}: 999 reports named {stem}-N.html already; give a name "
                        "with -o")


def report_command(args: argparse.Namespace) -> int:
    """``naseview report PATH [-o OUT.html] [--deidentified] [--case CASE_DIR]
    [--surgeon S] [--clinic C] [--patient-name P] [--pdf]``: the HTML (+ PNGs) and, with
    ``--pdf``, the PDF beside it (same name, ``.pdf``). An existing report is never
    overwritten: the default name is the first free ``report[-N].html``
    (:func:`free_report_name`), an ``-o`` name that exists is refused. A report with
    photos wanted but none found warns in one line on stderr."""
    path = Path(args.path)
    deid = bool(args.deidentified)
    if path.is_file():
        data = report_data_from_session(path, getattr(args, "case", None), not deid)
    elif current_set_file(path, RECONSTRUCTION_FILE).is_file():
        data = report_data_from_output(path, getattr(args, "case", None), not deid)
    else:
        raise NaseviewError(f"{path}: expected a session file (saved from the app) or a "
                            "`naseview reconstruct` output directory")
    data.surgeon = str(getattr(args, "surgeon", None) or "")
    data.clinic = str(getattr(args, "clinic", None) or "")
    data.patient_name = str(getattr(args, "patient_name", None) or "")
    if not deid and not data.photos:
        print(f"naseview report: warning: {path}: no photos found (the "
              f"{'session' if path.is_file() else 'output'} names no readable case "
              "folder), so the report has none; pass --case CASE_DIR to include them",
              file=sys.stderr)
    out = Path(args.output) if getattr(args, "output", None) else free_report_name(
        path.parent if path.is_file() else path,
        f"report{'-deidentified' if deid else ''}")
    written = write_report(data, out, deidentified=deid, overwrite=False)
    print(written)
    if getattr(args, "pdf", False):
        print(write_report_pdf(written, written.with_suffix(".pdf")))
    return 0
