"""Where a report's data comes from: a session file or ``naseview reconstruct`` output,
and the ``naseview report`` command."""

from __future__ import annotations

import argparse
import os
from pathlib import Path

import numpy as np

from naseview.case import read_case
from naseview.editing.baseline import baseline_from_output_dir
from naseview.editing.session import load_session
from naseview.errors import NaseviewError
from naseview.report.data import ReportData
from naseview.report.page import write_report

CaseDir = str | os.PathLike[str] | None
"""A case directory (SPEC §3) to take the photos from, or None (no photos)."""


def _photos_of(case_dir: CaseDir) -> dict[str, np.ndarray]:
    """View -> (H, W, 3) uint8 BGR photo of the case (empty when it cannot be read)."""
    if not case_dir:
        return {}
    try:
        case = read_case(Path(case_dir))
    except NaseviewError:
        return {}
    return {v: case.load_image(v) for v in case.views}


def report_data_from_session(path: str | os.PathLike[str], case_dir: CaseDir = None
                             ) -> ReportData:
    """A :class:`ReportData` from a ``naseview.session/1`` file (before = its baseline,
    after = its saved simulation when it has one); photos from ``case_dir`` or the case
    directory the session names."""
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


def report_data_from_output(out_dir: str | os.PathLike[str], case_dir: CaseDir = None
                            ) -> ReportData:
    """A "before only" :class:`ReportData` from ``naseview reconstruct`` output."""
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
