"""``naseview synth OUT_DIR [--model M] [--seed S] [--batch N] ...``: the command line."""

from __future__ import annotations

import argparse
from pathlib import Path

from naseview.errors import NaseviewError
from naseview.facemodel import load_face_model
from naseview.landmarks import VIEWS
from naseview.testbed.synth.rig import parse_views
from naseview.testbed.synth.scan import read_scan, synthesize_scan_case
from naseview.testbed.synth.synthesize import synthesize_case

ICT_CREDIT = "ICT Face Model (USC Institute for Creative Technologies, MIT)"


def check_synth_output(out: Path) -> None:
    """``out`` is a new folder or one ``naseview synth`` wrote (it has ``truth.json``): a
    photo case of a real patient there (``case.json`` without truth) is never replaced.

    Raises:
        NaseviewError: naming the folder and the fix.
    """
    if (out / "case.json").exists() and not (out / "truth.json").exists():
        raise NaseviewError(f"{out}: holds a case.json that naseview synth did not write (no "
                            "truth.json beside it); give a new or empty folder")


def _case_dirs(args: argparse.Namespace) -> list[Path]:
    """The case folders of a run, each checked by :func:`check_synth_output`: ``OUT_DIR``
    itself, or ``OUT_DIR/case-000..`` with ``--batch N``."""
    batch = int(args.batch or 0)
    if batch < 0:
        raise NaseviewError("--batch must be >= 0")
    out = Path(args.out_dir)
    dirs = [out / f"case-{i:03d}" for i in range(batch)] if batch else [out]
    for d in dirs:
        check_synth_output(d)
    return dirs


def _views(args: argparse.Namespace) -> tuple[str, ...]:
    """``--views`` (default the four photos) in SPEC order, checked."""
    text = getattr(args, "views", None)
    return VIEWS if text is None else parse_views(text)


def synth_command(args: argparse.Namespace) -> int:
    """One case into ``out_dir``, or ``--batch N`` cases ``out_dir/case-000..`` with seeds
    ``seed, seed + 1, ...``; prints each case directory (and the ICT credit).

    With ``--scan MESH --landmarks FILE [--texture IMAGE]`` the face is that scan (SPEC §8,
    :mod:`~naseview.testbed.synth.scan`) instead of a random face-model identity."""
    if getattr(args, "scan", None) is not None:
        return _scan_command(args)
    if getattr(args, "landmarks", None) is not None or getattr(args, "texture", None):
        raise NaseviewError("--landmarks and --texture go with --scan MESH")
    model = load_face_model(args.model or "ict")
    size = int(args.size)
    noise_px = float(args.noise_px)
    image_noise = float(args.image_noise)
    seed = int(args.seed)
    views = _views(args)
    dirs = _case_dirs(args)
    for i, d in enumerate(dirs):
        print(synthesize_case(d, model, seed + i, noise_px, size, image_noise,
                              views=views).parent)
    if model.name == "ict" or "ICT" in model.credit:
        print(f"face model: {ICT_CREDIT}")
    return 0


def _scan_command(args: argparse.Namespace) -> int:
    """``naseview synth OUT --scan MESH --landmarks FILE [--texture IMAGE] ...``."""
    if getattr(args, "model", None) is not None:
        raise NaseviewError("--model and --scan exclude each other: the scan is the face")
    if getattr(args, "landmarks", None) is None:
        raise NaseviewError("--scan needs --landmarks LANDMARKS.json (SPEC §8: the 21 "
                            "landmarks and both add helpers in the SPEC frame)")
    views = _views(args)
    dirs = _case_dirs(args)
    scan = read_scan(args.scan, args.landmarks, getattr(args, "texture", None))
    for i, d in enumerate(dirs):
        path = synthesize_scan_case(d, scan, int(args.seed) + i,
                                    float(args.noise_px), int(args.size),
                                    float(args.image_noise), views)
        print(path.parent)
    print(f"scan: {scan.source['credit']}")
    return 0
