"""The stage 2 / stage 3 parameters as the panel and a session file carry them.

The panel's number inputs give floats (:meth:`naseview.app.panels.Panels.param_values`);
a session file stores the plain-valued fields and is read back by a later version whose
parameters may have been renamed. These helpers turn one into the other for
:class:`naseview.stage2_curves.CurveParams` and :class:`naseview.stage3_mesh.RefineParams`.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from dataclasses import fields, replace
from typing import Any, TypeVar

from naseview.stage2_curves import CurveParams
from naseview.stage3_mesh import RefineParams

log = logging.getLogger(__name__)

_P = TypeVar("_P", CurveParams, RefineParams)


def typed_values(params: CurveParams | RefineParams, values: Mapping[str, Any]) -> dict[str, Any]:
    """Panel values with integers rounded where the parameter field is an ``int``."""
    out = {}
    for k, v in values.items():
        cur = getattr(params, k)
        out[k] = int(round(v)) if isinstance(cur, int) and not isinstance(cur, bool) else v
    return out


def with_saved(params: _P, saved: Mapping[str, Any], where: str) -> _P:
    """``params`` with the values a session saved (fields it no longer has are logged and
    left out: a session outlives a renamed parameter)."""
    names = {f.name for f in fields(params)}
    unknown = sorted(set(saved) - names)
    if unknown:
        log.warning("naseview: %s: parameters %s are not fields of %s; left out", where,
                    ", ".join(unknown), type(params).__name__)
    return replace(params, **{k: v for k, v in saved.items() if k in names})


def plain_values(params: CurveParams | RefineParams) -> dict[str, int | float | str | bool]:
    """The plain-valued fields of a params object (what a session file stores)."""
    out: dict[str, int | float | str | bool] = {}
    for f in fields(params):
        v = getattr(params, f.name)
        if isinstance(v, (int, float, str, bool)):
            out[f.name] = v
    return out


__all__ = ["plain_values", "typed_values", "with_saved"]
