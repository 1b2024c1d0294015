"""The report's images: PNG encoding, the views and photos sheets, the table as a picture.

Every image is (H, W, 3) uint8 BGR; PNGs carry no metadata.
"""

from __future__ import annotations

import base64
from collections.abc import Mapping

import cv2
import numpy as np

from naseview.errors import NaseviewError
from naseview.landmarks import VIEWS
from naseview.report.data import DISCLAIMER
from naseview.report.table import MeasurementRow, format_change, format_value
from naseview.report.views import RENDER_VIEWS


def png_bytes(image_bgr: np.ndarray) -> bytes:
    """PNG encoding of an (H, W, 3) uint8 BGR image (no metadata)."""
    ok, buf = cv2.imencode(".png", image_bgr)
    if not ok:
        raise NaseviewError("could not encode a report image as PNG")
    return buf.tobytes()


def data_uri(image_bgr: np.ndarray) -> str:
    """``data:image/png;base64,...`` of an image, for embedding in the HTML."""
    return "data:image/png;base64," + base64.b64encode(png_bytes(image_bgr)).decode("ascii")


def fit(image_bgr: np.ndarray, max_side: int) -> np.ndarray:
    """The image downscaled (area interpolation) so its longest side is at most
    ``max_side`` px; unchanged when already small enough."""
    h, w = image_bgr.shape[:2]
    s = max_side / float(max(h, w))
    if s >= 1.0:
        return image_bgr
    return cv2.resize(image_bgr, (max(1, round(w * s)), max(1, round(h * s))),
                      interpolation=cv2.INTER_AREA)


def _label(img: np.ndarray, text: str) -> np.ndarray:
    """A copy of ``img`` with ``text`` written in its top-left corner."""
    out = img.copy()
    cv2.putText(out, text, (10, 26), cv2.FONT_HERSHEY_SIMPLEX, 0.7, (60, 60, 60), 2,
                cv2.LINE_AA)
    return out


def views_sheet(before: Mapping[str, np.ndarray], after: Mapping[str, np.ndarray] | None
                ) -> np.ndarray:
    """A grid PNG: one row per view (:data:`RENDER_VIEWS` order), before on the left and
    (if given) after on the right."""
    rows = []
    for v in RENDER_VIEWS:
        tiles = [_label(before[v], "before")]
        if after:
            tiles.append(_label(after[v], "after (simulation)"))
        rows.append(np.hstack(tiles))
    return np.vstack(rows)


def photos_sheet(photos: Mapping[str, np.ndarray], height: int = 360) -> np.ndarray:
    """The photos side by side at a common height (BGR), in SPEC view order."""
    tiles = []
    for v in VIEWS:
        if v not in photos:
            continue
        p = photos[v]
        s = height / float(p.shape[0])
        tiles.append(_label(cv2.resize(p, (max(1, round(p.shape[1] * s)), height),
                                       interpolation=cv2.INTER_AREA), v))
    if not tiles:
        return np.full((height, height, 3), 255, np.uint8)
    return np.hstack(tiles)


def _ascii(text: str) -> str:
    """``text`` in the characters OpenCV's Hershey fonts can draw."""
    return (text.replace("°", " deg").replace("—", "-").replace("–", "-")
            .replace("±", "+-")
            .encode("ascii", "replace").decode("ascii"))


def measurements_image(rows: list[MeasurementRow], width: int = 900) -> np.ndarray:
    """The patient's measurements table drawn as an image (BGR), for the PNG output:
    title, before, after, change and the usual range in grey; no flags, no colours. An
    estimate says so after its title with its sd ("Radix height (est. +- 2.4 mm)")."""
    rows = [r for r in rows if r["group"] == "clinical"]
    line = 30
    h = line * (len(rows) + 3) + 10
    img = np.full((h, width, 3), 255, np.uint8)
    font = cv2.FONT_HERSHEY_SIMPLEX
    cols = (10, 330, 450, 570, 670)
    heads = ("measurement", "before", "after", "change", "usual adult range")
    for x, t in zip(cols, heads, strict=True):
        cv2.putText(img, t, (x, line), font, 0.55, (0, 0, 0), 1, cv2.LINE_AA)
    for k, r in enumerate(rows):
        y = line * (k + 2)
        if k % 2 == 0:
            cv2.rectangle(img, (0, y - line + 8), (width, y + 8), (245, 245, 245), -1)
        est = f" (est. ± {r['sd']:.1f} mm)" if r["sd"] is not None else ""
        vals = (r["title"] + (" (calliper)" if r["calliper"] else "") + est,
                format_value(r["before"], r["unit"]),
                format_value(r["after"], r["unit"]),
                format_change(r["before"], r["after"], r["unit"]),
                r["usual"].replace("usual range ", ""))
        for j, (x, t) in enumerate(zip(cols, vals, strict=True)):
            grey = (120, 120, 120) if j == 4 else (0, 0, 0)
            cv2.putText(img, _ascii(t), (x, y), font, 0.5 if j == 4 else 0.55, grey, 1,
                        cv2.LINE_AA)
    cv2.putText(img, DISCLAIMER, (10, h - 14), font, 0.6, (40, 40, 40), 2, cv2.LINE_AA)
    return img
