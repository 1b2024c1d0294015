"""``naseview synth OUT_DIR [--model M] [--seed S] [--batch N] ...``: the command line."""

from __future__ import annotations

import argparse
from pathlib import Path

from naseview.errors import NaseviewError
from naseview.facemodel import load_face_model
from naseview.testbed.synth.synthesize import synthesize_case

ICT_CREDIT = "ICT Face Model (USC Institute for Creative Technologies, MIT)"


def synth_command(args: argparse.Namespace) -> int:
    """One case into ``out_dir``, or ``--batch N`` cases ``out_dir/case-000..`` with seeds
    ``seed, seed + 1, ...``; prints each case directory (and the ICT credit)."""
    model = load_face_model(args.model)
    size = int(args.size)
    noise_px = float(args.noise_px)
    image_noise = float(args.image_noise)
    seed = int(args.seed)
    batch = int(args.batch or 0)
    if batch < 0:
        raise NaseviewError("--batch must be >= 0")
    out = Path(args.out_dir)
    if batch:
        for i in range(batch):
            path = synthesize_case(out / f"case-{i:03d}", model, seed + i, noise_px, size,
                                   image_noise)
            print(path.parent)
    else:
        path = synthesize_case(out, model, seed, noise_px, size, image_noise)
        print(path.parent)
    if model.name == "ict" or "ICT" in model.credit:
        print(f"face model: {ICT_CREDIT}")
    return 0
