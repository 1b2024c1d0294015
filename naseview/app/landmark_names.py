"""Readable landmark names for the 3D labels, with the side: "Alar crease (L)".

The paper's abbreviations (``al``, ``ac``, ``int`` …, :data:`naseview.landmarks.LANDMARKS`)
stay in the exports and the surgeon's tooltips; a label in the view says what the point
is, and which side of the subject it is on (SPEC §2: left = the subject's left, +x).

>>> display_name("ac_l")
'Alar crease (L)'
>>> display_name("prn")
'Tip (pronasale)'
"""

from __future__ import annotations

from naseview.landmarks import LANDMARKS

NAMES: dict[str, str] = {
    "g": "Glabella", "n": "Nasion", "k": "Kyphion", "r": "Rhinion",
    "prn": "Tip (pronasale)", "c": "Columella", "sn": "Subnasale",
    "mf": "Orbital rim", "int": "Alar groove, top", "al": "Ala, widest",
    "alp": "Ala meets lobule", "alpp": "Nostril sill", "ac": "Alar crease",
    "md": "Alar rim arch", "add": "Base outline",
}
"""Base id (without ``_l`` / ``_r``) -> readable name."""


def display_name(lid: str) -> str:
    """Readable name of landmark ``lid`` with ``(L)`` / ``(R)`` for the subject's side;
    an unknown id is returned as it is."""
    info = LANDMARKS.get(lid)
    base = lid[:-2] if info is not None and info.side in ("l", "r") else lid
    name = NAMES.get(base, info.paper if info is not None else lid)
    if info is not None and info.side in ("l", "r"):
        return f"{name} ({info.side.upper()})"
    return name


__all__ = ["NAMES", "display_name"]
