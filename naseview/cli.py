"""The ``naseview`` command: one subcommand per job, each a thin call into the library.

Errors meant for the user (:class:`~naseview.errors.NaseviewError`) print as one line and
exit with status 2; nothing here does real work itself.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

from naseview.errors import NaseviewError
from naseview.stages import STAGE_TITLES

Command = Callable[[argparse.Namespace], int]


def _command(module: str, name: str) -> Command:
    """The subcommand function ``module.name``, imported when it runs.

    Lazy on purpose (measured on 2 cores): importing every subcommand's module at start-up
    made ``naseview --help`` and ``naseview model info`` take 1.4 s instead of 0.14 s.
    """

    def run(args: argparse.Namespace) -> int:
        func: Command = getattr(importlib.import_module(module), name)
        return func(args)

    run.__name__ = name
    return run


synth_command = _command("naseview.testbed.synth", "synth_command")
sheet_command = _command("naseview.testbed.sheet", "sheet_command")
reconstruct_command = _command("naseview.pipeline", "reconstruct_command")
evaluate_command = _command("naseview.testbed.evaluate", "evaluate_command")
serve_command = _command("naseview.app.serve", "serve_command")
report_command = _command("naseview.report", "report_command")
model_command = _command("naseview.facemodel.store", "model_command")


def build_parser() -> argparse.ArgumentParser:
    """The ``naseview`` argument parser: one subcommand per job, each with its ``func``."""
    p = argparse.ArgumentParser(
        prog="naseview",
        description="3D nose reconstruction from four photos and 21 landmarks "
                    "(Toan, Tuan, Thinh, CMES 2025), without neural networks.")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")

    s = sub.add_parser("synth", help="render synthetic cases with known ground truth")
    s.add_argument("out_dir", type=Path, help="output case directory (a parent with --batch)")
    s.add_argument("--model", default=None,
                   help="face model of the synthetic identity: ict (default), generic or a "
                        ".npz path")
    s.add_argument("--scan", type=Path, default=None,
                   help="render this face scan (OBJ with MTL/texture, or PLY; mm) instead "
                        "of a face-model identity; needs --landmarks")
    s.add_argument("--landmarks", type=Path, default=None,
                   help="the scan's landmarks (SPEC §8 naseview.scan-landmarks/1 JSON)")
    s.add_argument("--texture", type=Path, default=None,
                   help="texture image of the scan (default: the OBJ's MTL map_Kd)")
    s.add_argument("--seed", type=int, default=0, help="random seed (identity, rig, skin)")
    s.add_argument("--noise-px", type=float, default=1.5,
                   help="Gaussian click noise, pixels (default 1.5)")
    s.add_argument("--size", type=int, default=1024, help="photo size in pixels")
    s.add_argument("--batch", type=int, default=0,
                   help="write N cases case-000.. under OUT_DIR (seeds 0..N-1 + --seed)")
    s.add_argument("--image-noise", type=float, default=2.0,
                   help="photo sensor noise, grey levels (0 for none)")
    s.add_argument("--views", default=None,
                   help="photos to render, comma list: front,left,right,bottom (default) "
                        "and optionally oblique_left,oblique_right (45 deg three-quarter "
                        "views)")
    s.set_defaults(func=synth_command)

    s = sub.add_parser("sheet", help="PNG contact sheet of a case's photos with clicks")
    s.add_argument("case_dir", type=Path)
    s.add_argument("-o", "--output", type=Path, required=True, help="PNG file to write")
    s.add_argument("--reconstruction", type=Path, default=None,
                   help="also draw reprojected landmarks and curves of this reconstruction")
    s.set_defaults(func=sheet_command)

    s = sub.add_parser("reconstruct", help="reconstruct a case directory")
    s.add_argument("case_dir", type=Path)
    s.add_argument("-o", "--output", type=Path, required=True, help="output directory")
    s.add_argument("--model", default=None,
                   help="base face model: ict, generic or a .npz path (default: ict if "
                        "installed, else generic)")
    s.add_argument("--export", action="append", default=[], choices=["stl", "obj", "glb"],
                   help="also export face and nose meshes in this format (repeatable; "
                        "glb: with the photo texture, as the app's download)")
    s.add_argument("--stages", default="1,2,3",
                   help="stages to run, e.g. 1 or 1,2 (default 1,2,3; 1 is always needed): "
                        + "; ".join(STAGE_TITLES.values()))
    s.set_defaults(func=reconstruct_command)

    s = sub.add_parser("evaluate", help="accuracy against synthetic ground truth (paper "
                                        "Tables 1, 2, 4, 5 and surface error)",
                       epilog="exit status: 0 every case evaluated, 1 some cases failed "
                              "(each listed as FAILED with its reason), 2 none could be")
    s.add_argument("case_dirs", type=Path, nargs="+")
    s.add_argument("--json", action="store_true", help="print machine-readable JSON")
    s.add_argument("--model", default=None, help="base face model for stage 3")
    s.add_argument("--stages", default="1,2,3",
                   help="stages to run and evaluate: " + "; ".join(STAGE_TITLES.values()))
    s.add_argument("--maps", type=Path, default=None, metavar="DIR",
                   help="write each case's nose surface error colour map (front, profile, "
                        "below; mm colour bar) into DIR as <case>-surface-error.png")
    s.add_argument("--no-ablation", action="store_true",
                   help="skip the stage-3 ablation rows (faster)")
    s.set_defaults(func=evaluate_command)

    s = sub.add_parser("serve", help="open the 3D viewer / editor in the browser (one "
                                     "view per tab, one simulation per patient)")
    s.add_argument("path", type=Path, nargs="?", default=None,
                   help="case directory, reconstruction directory or session file "
                        "(default: the bundled demo case)")
    s.add_argument("--host", default="127.0.0.1",
                   help="interface to bind (default 127.0.0.1: this computer only)")
    s.add_argument("--port", type=int, default=8080)
    s.add_argument("--model", default=None, help="base face model for reconstruction")
    s.add_argument("--new", action="store_true",
                   help="start with the new-patient page (the demo case is not opened): "
                        "upload four photos (two obliques optional) and click the "
                        "landmarks (kept in $NASEVIEW_WORK_DIR or ~/naseview-patients)")
    s.add_argument("--no-browser", action="store_true",
                   help="do not open the page in the browser (just print its address)")
    s.set_defaults(func=serve_command)

    s = sub.add_parser("report", help="consultation report (self-contained HTML + PNGs, "
                                      "optionally A4 PDF) from a session file or a "
                                      "reconstruction directory")
    s.add_argument("path", type=Path,
                   help="session .json saved from the app (before + after) or a "
                        "`naseview reconstruct` output directory (before only)")
    s.add_argument("-o", "--output", type=Path, default=None,
                   help="HTML file to write (default: report.html beside PATH)")
    s.add_argument("--deidentified", action="store_true",
                   help="leave out the photos, notes, names, ids, dates, surgeon and "
                        "clinic; clean grey renders of the nose only")
    s.add_argument("--case", type=Path, default=None,
                   help="case directory with the photos (default: the one PATH names)")
    s.add_argument("--surgeon", default="", help="surgeon's name shown in the report")
    s.add_argument("--clinic", default="", help="clinic name shown in the report")
    s.add_argument("--patient-name", default="",
                   help="patient's name: the title of the report (default: the case id)")
    s.add_argument("--pdf", action="store_true",
                   help="also print the report to an A4 PDF beside the HTML (needs "
                        "Chromium)")
    s.set_defaults(func=report_command)

    s = sub.add_parser("model", help="install or inspect face models")
    msub = s.add_subparsers(dest="model_command", required=True, metavar="ACTION")
    m = msub.add_parser("import-ict", help="import an ICT-FaceKit checkout (or its "
                                           "FaceXModel folder, a converted .npz, or a "
                                           "folder holding ict_face_light.npz)")
    m.add_argument("source", type=Path)
    m.set_defaults(func=model_command)
    m = msub.add_parser("fetch", help="download the ICT Face Model files from GitHub "
                                      "(the only network access naseview makes)")
    m.add_argument("--url", default=None, help="alternative base URL of FaceXModel/")
    m.set_defaults(func=model_command)
    m = msub.add_parser("info", help="list installed face models")
    m.set_defaults(func=model_command)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``naseview`` console command."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except NaseviewError as e:
        print(f"naseview: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("naseview: interrupted", file=sys.stderr)
        return 130
    except Exception as e:  # a bug, not a user error: still one line unless debugging
        if os.environ.get("NASEVIEW_DEBUG"):
            raise
        print(f"naseview: internal error: {type(e).__name__}: {e} (set NASEVIEW_DEBUG=1 "
              "for the traceback and please report it)", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
