"""The planned manoeuvres in words and figures, for the report.

:func:`plan_sentences` gives the patient sentences of
:func:`naseview.editing.manoeuvres.describe_plan` ("Lower the bump on the bridge of the
nose by 2 mm"), :func:`plan_figures` the surgeon's title and amount of each manoeuvre
(:data:`naseview.editing.manoeuvres.MANOEUVRES`); without that package, both fall back to
``"name: amount"`` lines.

Example
-------
>>> plan_figures({"hump_reduction": 2.0})[0][1]
'2 mm'
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

_describe: Callable[[Mapping[str, float]], list[str]] | None
_catalogue: Mapping[str, Any]
try:
    from naseview.editing.manoeuvres import MANOEUVRES as _MANOEUVRES
    from naseview.editing.manoeuvres import describe_plan as _describe_plan
    _describe, _catalogue = _describe_plan, _MANOEUVRES
except ImportError:  # pragma: no cover - before naseview.editing.manoeuvres lands
    _describe, _catalogue = None, {}

_UNITS = {"mm": "mm", "deg": "°"}


def _planned(amounts: Mapping[str, float]) -> dict[str, float]:
    """The non-zero, finite amounts."""
    return {str(k): float(v) for k, v in amounts.items()
            if math.isfinite(float(v)) and float(v) != 0.0}


def _amount(x: float, unit: str) -> str:
    """``"2 mm"``, ``"-5°"``."""
    u = _UNITS.get(unit, unit)
    return f"{x:g}{u}" if u == "°" else f"{x:g} {u}".strip()


def plan_figures(amounts: Mapping[str, float]) -> list[tuple[str, str]]:
    """(title, amount with unit) of each planned manoeuvre, in catalogue order
    (``("Dorsal hump reduction", "2 mm")``); without the catalogue, the name with
    underscores as spaces and the bare number."""
    planned = _planned(amounts)
    names = [n for n in _catalogue if n in planned] + [n for n in planned
                                                       if n not in _catalogue]
    out = []
    for n in names:
        info = _catalogue.get(n)
        title = str(getattr(info, "title", "") or n.replace("_", " "))
        each = " per side" if getattr(info, "per_side", False) else ""
        out.append((title, _amount(planned[n], str(getattr(info, "unit", ""))) + each))
    return out


def plan_sentences(amounts: Mapping[str, float]) -> list[str]:
    """Patient sentences of the planned manoeuvres (``describe_plan``), or the fallback
    ``"name: amount"`` lines before the manoeuvres package exists; ``[]`` for no plan."""
    planned = _planned(amounts)
    if not planned:
        return []
    if _describe is not None:
        return list(_describe(planned))
    return [f"{t}: {a}" for t, a in plan_figures(planned)]
