"""The three stages' names, one vocabulary for folders, progress lines, docs and messages.

>>> STAGE_TITLES[1]
'stage 1 — landmarks (paper §3.2)'
"""

from __future__ import annotations

STAGE_NAMES: dict[int, str] = {1: "landmarks", 2: "curves", 3: "mesh"}
"""Stage number -> name: the folders ``stage1_landmarks``, ``stage2_curves`` and
``stage3_mesh``, the keys of ``stage_seconds`` and the progress lines."""

STAGE_TITLES: dict[int, str] = {
    n: f"stage {n} — {STAGE_NAMES[n]} (paper §{section})"
    for n, section in ((1, "3.2"), (2, "3.3"), (3, "3.4"))
}
"""Stage number -> the title docs and messages use, e.g. ``"stage 1 — landmarks (paper §3.2)"``."""
