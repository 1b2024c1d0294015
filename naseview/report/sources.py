"""Where a report's data comes from: a session file or ``naseview reconstruct`` output,
and the ``naseview report`` command."""

from __future__ import annotations

import argparse
import os
from collections.abc import Callable
from pathlib import Path

import numpy as np

from naseview.case import read_case
from naseview.editing.baseline import Baseline, baseline_from_output_dir
from naseview.editing.session import load_session
from naseview.errors import NaseviewError
from naseview.fileio import current_set_file
from naseview.reconstruction import RECONSTRUCTION_FILE, Reconstruction, output_case_dir
from naseview.report.data import ReportData
from naseview.report.page import write_report
from naseview.texture.bake import FaceTexture, skin_texture

CaseDir = str | os.PathLike[str] | None
"""A case directory (SPEC §3) to take the photos from, or None (no photos)."""


def _photos_of(case_dir: CaseDir) -> dict[str, np.ndarray]:
    """View -> (H, W, 3) uint8 BGR photo of the case (empty without a case folder).

    Raises:
        NaseviewError: the case folder cannot be read (its own one-line error).
    """
    if not case_dir:
        return {}
    case = read_case(Path(case_dir))
    return {v: case.load_image(v) for v in case.views}


def _stored_photos(find: Callable[[], Path | None], where: Path) -> dict[str, np.ndarray]:
    """The photos of the case folder a session or output folder names (``find``), with
    the fix added to the error when it is refused or cannot be read."""
    try:
        return _photos_of(find())
    except NaseviewError as e:
        raise NaseviewError(f"{e} (photos named by {where}; pass --case CASE_DIR, or "
                            "--deidentified for a report without photos)") from None


def report_data_from_session(path: str | os.PathLike[str], case_dir: CaseDir = None,
                             photos: bool = True) -> ReportData:
    """A :class:`ReportData` from a ``naseview.session/1`` file (before = its baseline,
    after = its saved simulation when it has one); photos (unless ``photos`` is False)
    from ``case_dir`` or the case folder the session names
    (:meth:`~naseview.editing.session.Session.case_folder`: inside the session file's
    folder only).

    Raises:
        NaseviewError: a bad session file, or a case folder that is refused or unreadable.
    """
    s = load_session(path)
    b = s.baseline
    sim = s.simulation
    edited = sim is not None and not np.array_equal(sim.V, b.V)
    pics = {} if not photos else (_photos_of(case_dir) if case_dir
                                  else _stored_photos(s.case_folder, Path(path)))
    return ReportData(
        case_id=str(s.app.get("case_id", Path(path).stem)), V_before=b.V, F=b.F,
        nose_ids=b.nose_ids, measurements_before=dict(b.measurements),
        V_after=sim.V if edited and sim is not None else None,
        measurements_after=dict(sim.measurements) if edited and sim is not None else None,
        photos=pics, credit=str(s.app.get("credit", "")), texture=_skin(b, pics))


def report_data_from_output(out_dir: str | os.PathLike[str], case_dir: CaseDir = None,
                            photos: bool = True) -> ReportData:
    """A "before only" :class:`ReportData` from ``naseview reconstruct`` output; photos
    (unless ``photos`` is False) from ``case_dir``, the case folder the output names
    (:func:`~naseview.reconstruction.output_case_dir`) or the output folder itself when
    it holds ``case.json``."""
    out = Path(out_dir)
    b = baseline_from_output_dir(out)
    rec = b.reconstruction

    def stored() -> Path | None:
        return output_case_dir(out, rec) or (out if (out / "case.json").is_file() else None)

    pics = {} if not photos else (_photos_of(case_dir) if case_dir
                                  else _stored_photos(stored, out / RECONSTRUCTION_FILE))
    return ReportData(case_id=out.name, V_before=b.V, F=b.F, nose_ids=b.nose_ids,
                      measurements_before=dict(b.measurements), photos=pics,
                      credit=_credit_of(rec), texture=_skin(b, pics))


def _skin(baseline: Baseline, photos: dict[str, np.ndarray]) -> FaceTexture | None:
    """The patient's skin for the report's renders, baked from the photos with the
    reconstruction's cameras (None without photos)."""
    rec = baseline.reconstruction
    return skin_texture(baseline.V, baseline.F, rec.cameras, photos) if rec else None


def _credit_of(rec: Reconstruction | None) -> str:
    """The face model's credit line recorded by stage 3 (``mesh.credit``), or ""."""
    mesh = rec.extra.get("mesh") if rec is not None else None
    return str(mesh.get("credit", "")) if isinstance(mesh, dict) else ""


def report_command(args: argparse.Namespace) -> int:
    """``naseview report PATH [-o OUT.html] [--deidentified] [--case CASE_DIR]``."""
    path = Path(args.path)
    photos = not args.deidentified
    if path.is_file():
        data = report_data_from_session(path, getattr(args, "case", None), photos)
    elif current_set_file(path, RECONSTRUCTION_FILE).is_file():
        data = report_data_from_output(path, getattr(args, "case", None), photos)
    else:
        raise NaseviewError(f"{path}: expected a session file (saved from the app) or a "
                            "`naseview reconstruct` output directory")
    out = Path(args.output) if getattr(args, "output", None) else (
        (path.parent if path.is_file() else path)
        / f"report{'-deidentified' if args.deidentified else ''}.html")
    written = write_report(data, out, deidentified=bool(args.deidentified))
    print(written)
    return 0
