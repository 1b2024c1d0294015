"""Benchmarks read the ICT Face Model Light from ``../shared`` beside the repository (as
the tests do) unless ``NASEVIEW_ICT_MODEL`` or an installed model says otherwise."""

from __future__ import annotations

import os
from pathlib import Path

SHARED_ICT_NPZ = (Path(__file__).resolve().parents[2] / "shared" / "data" / "ict-face-model"
                  / "ict_face_light.npz")


def use_shared_ict() -> None:
    """Point naseview at the shared ICT model if present and nothing else was chosen."""
    if SHARED_ICT_NPZ.is_file():
        os.environ.setdefault("NASEVIEW_ICT_MODEL", str(SHARED_ICT_NPZ))
