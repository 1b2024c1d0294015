"""Soft weights and palette picks shared by every painted part of the synthetic face.

Example
-------
>>> import numpy as np
>>> smoothstep(np.array([-1.0, 0.5, 2.0])).tolist()
[0.0, 0.5, 1.0]
>>> interp_rgb(((0, 0, 255), (255, 0, 255)), 0.5).round(3).tolist()
[1.0, 0.0, 0.5]
"""

from __future__ import annotations

import numpy as np


def smoothstep(x: np.ndarray) -> np.ndarray:
    """Cubic ``3t^2 - 2t^3`` of ``t = clip(x, 0, 1)``, elementwise (same shape as x)."""
    t = np.clip(x, 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def interp_rgb(table: tuple[tuple[float, float, float], ...], t: float) -> np.ndarray:
    """(3,) piecewise-linear pick along ``table`` (K RGB 0-255 anchors) at ``t`` in
    [0, 1]; returned as BGR in [0, 1]."""
    x = np.linspace(0.0, 1.0, len(table))
    rgb = np.array([np.interp(t, x, [c[k] for c in table]) for k in range(3)])
    return rgb[::-1] / 255.0
