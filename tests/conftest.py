"""Shared fixtures. The ICT Face Model Light is read from ``../shared`` (never copied)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SHARED_ICT = REPO.parent / "shared" / "data" / "ict-face-model"

# Point naseview at the shared ICT model unless the caller chose one.
if (SHARED_ICT / "ict_face_light.npz").is_file():
    os.environ.setdefault("NASEVIEW_ICT_MODEL", str(SHARED_ICT / "ict_face_light.npz"))


@pytest.fixture(scope="session")
def ict_dir() -> Path:
    """``../shared/data/ict-face-model`` (fails loudly if absent: CI must provide it)."""
    assert (SHARED_ICT / "ict_face_light.npz").is_file(), (
        f"{SHARED_ICT} not found; the tests need ../shared beside the repository")
    return SHARED_ICT
