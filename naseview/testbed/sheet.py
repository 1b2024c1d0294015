"""Contact sheet of a case: ``naseview sheet CASE_DIR -o sheet.png``.

The four photos in a 2 x 2 grid (front, left / right, bottom), the oblique photos a third
row when the case has them (oblique_left, oblique_right), downscaled, with every
click drawn as a cross and its id, the view name as a title, and optionally the landmarks
and curves of a reconstruction (or of a synthetic case's ``truth.json``, same schema)
reprojected with that reconstruction's cameras, so click errors and bad fits stand out.

Colours (BGR): clicks yellow crosses (helpers ``add_*`` magenta), reprojected landmarks
red circles joined to their click by a thin red line, reprojected curves cyan.

Example
-------
>>> from naseview.case import read_case
>>> img = contact_sheet(read_case("assets/demo-case"))     # doctest: +SKIP
>>> img.shape                                              # doctest: +SKIP
(1368, 1280, 3)
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Callable, Mapping
from pathlib import Path

import cv2
import numpy as np

from naseview.camera import Camera
from naseview.case import Case, read_case
from naseview.errors import NaseviewError
from naseview.fileio import atomic_write_bytes
from naseview.landmarks import ALL_VIEWS, HELPER_IDS
from naseview.reconstruction import Reconstruction, read_reconstruction

CLICK_BGR = (0, 255, 255)
HELPER_BGR = (255, 0, 255)
RECON_BGR = (0, 0, 255)
CURVE_BGR = (255, 255, 0)
TITLE_H = 30
LEGEND_H = 28


def _text(img: np.ndarray, text: str, org: tuple[int, int], scale: float,
          color: tuple[int, int, int]) -> int:
    """Text with a dark outline, readable on any backdrop; returns its width (px)."""
    font = cv2.FONT_HERSHEY_SIMPLEX
    for dx, dy in ((-1, 0), (1, 0), (0, -1), (0, 1), (-1, -1), (1, 1), (-1, 1), (1, -1)):
        cv2.putText(img, text, (org[0] + dx, org[1] + dy), font, scale, (0, 0, 0), 1,
                    cv2.LINE_AA)
    cv2.putText(img, text, org, font, scale, color, 1, cv2.LINE_AA)
    return int(cv2.getTextSize(text, font, scale, 1)[0][0])


def _project_visible(cam: Camera, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(N, 2) pixels and (N,) bool "in front of the camera" for world points (N, 3)."""
    X = np.asarray(X, dtype=np.float64).reshape(-1, 3)
    front = cam.depth(X) > 1e-6
    uv = np.full((len(X), 2), np.nan)
    if front.any():
        uv[front] = cam.project(X[front])
    return uv, front


def _to_tile(s: float) -> Callable[[np.ndarray], tuple[int, int]]:
    """Photo pixel (2,) -> tile point with 4 fractional bits, for a tile ``s`` times the
    photo (pixel centres: ``x_tile = (x + 0.5) s - 0.5``)."""
    def px(uv: np.ndarray) -> tuple[int, int]:
        return (int(round(((uv[0] + 0.5) * s - 0.5) * 16)),
                int(round(((uv[1] + 0.5) * s - 0.5) * 16)))

    return px


def _draw_reconstruction(img: np.ndarray, cam: Camera, reconstruction: Reconstruction,
                         clicks: Mapping[str, np.ndarray],
                         px: Callable[[np.ndarray], tuple[int, int]]) -> list[float]:
    """Reprojected curves (cyan) and landmarks (red circles joined to their click);
    returns the reprojection error (px) of every clicked landmark."""
    for pts in reconstruction.curves.values():
        uv, front = _project_visible(cam, pts)
        for a, b, fa, fb in zip(uv[:-1], uv[1:], front[:-1], front[1:], strict=True):
            if fa and fb:
                cv2.line(img, px(a), px(b), CURVE_BGR, 1, cv2.LINE_AA, 4)
    errs = []
    for lid, X in reconstruction.landmarks.items():
        uv, front = _project_visible(cam, X)
        if not front[0]:
            continue
        p = px(uv[0])
        cv2.circle(img, p, 5 * 16, RECON_BGR, 1, cv2.LINE_AA, 4)
        if lid in clicks:
            cv2.line(img, p, px(clicks[lid]), RECON_BGR, 1, cv2.LINE_AA, 4)
            errs.append(float(np.linalg.norm(uv[0] - clicks[lid])))
    return errs


def _draw_clicks(img: np.ndarray, clicks: Mapping[str, np.ndarray],
                 px: Callable[[np.ndarray], tuple[int, int]]) -> None:
    """Every click as an outlined cross with its id (helpers magenta, others yellow)."""
    for lid, uv in clicks.items():
        color = HELPER_BGR if lid in HELPER_IDS else CLICK_BGR
        p = px(uv)
        d = 5 * 16
        for q0, q1 in (((p[0] - d, p[1]), (p[0] + d, p[1])), ((p[0], p[1] - d), (p[0], p[1] + d))):
            cv2.line(img, q0, q1, (0, 0, 0), 3, cv2.LINE_AA, 4)
            cv2.line(img, q0, q1, color, 1, cv2.LINE_AA, 4)
        _text(img, lid, (p[0] // 16 + 5, p[1] // 16 - 4), 0.36, color)


def view_tile(case: Case, view: str, tile: int,
              reconstruction: Reconstruction | None = None) -> np.ndarray:
    """One annotated, downscaled photo of ``case`` with its title bar.

    Args:
        case: the case.
        view: view name.
        tile: width of the tile in pixels (the photo keeps its aspect ratio).
        reconstruction: optional result whose landmarks and curves are reprojected.
    Returns:
        (TITLE_H + h, tile, 3) uint8 BGR.
    """
    v = case.views[view]
    photo = case.load_image(view)
    h0, w0 = photo.shape[:2]
    s = tile / w0
    img = cv2.resize(photo, (tile, max(1, int(round(h0 * s)))), interpolation=cv2.INTER_AREA)
    px = _to_tile(s)
    title = f"{view}  ({v.image}, {len(v.landmarks)} clicks)"
    cam = reconstruction.cameras.get(view) if reconstruction is not None else None
    if reconstruction is not None and cam is not None:
        errs = _draw_reconstruction(img, cam, reconstruction, v.landmarks, px)
        if errs:
            title += f", reprojection mean {np.mean(errs):.2f} px"
    _draw_clicks(img, v.landmarks, px)
    bar = np.full((TITLE_H, tile, 3), 40, dtype=np.uint8)
    _text(bar, title, (8, 21), 0.55, (255, 255, 255))
    return np.vstack([bar, img])


def contact_sheet(case: Case, reconstruction: Reconstruction | None = None,
                  tile: int = 640) -> np.ndarray:
    """The 2 x 2 sheet (front, left / right, bottom; a third row with the obliques the case
    has) with a legend line.

    Args:
        case: a validated case.
        reconstruction: optional reconstruction (or truth) to reproject.
        tile: width of each photo tile (px).
    Returns:
        (H, 2 tile, 3) uint8 BGR.
    """
    tiles = [view_tile(case, view, tile, reconstruction) for view in ALL_VIEWS
             if view in case.views]
    hmax = max(t.shape[0] for t in tiles)
    tiles = [np.vstack([t, np.zeros((hmax - t.shape[0], tile, 3), np.uint8)]) for t in tiles]
    if len(tiles) % 2:   # one oblique: an empty tile beside it
        tiles.append(np.zeros_like(tiles[0]))
    grid = np.vstack([np.hstack(tiles[i:i + 2]) for i in range(0, len(tiles), 2)])
    legend = np.full((LEGEND_H, grid.shape[1], 3), 40, dtype=np.uint8)
    x = 8
    items = [(f"case {case.id}:", (255, 255, 255)), ("+ click", CLICK_BGR),
             ("+ helper (add)", HELPER_BGR)]
    if reconstruction is not None:
        items += [("o reprojected landmark", RECON_BGR), ("- reprojected curves", CURVE_BGR)]
    for text, color in items:
        x += _text(legend, text, (x, 19), 0.5, color) + 24
    return np.vstack([grid, legend])


def _load_reconstruction(path: Path) -> Reconstruction:
    p = Path(path)
    if p.is_dir():
        p = p / "reconstruction.json"
    return read_reconstruction(p)


def write_sheet(case_dir: str | os.PathLike[str], output: str | os.PathLike[str],
                reconstruction: str | os.PathLike[str] | None = None,
                tile: int = 640) -> Path:
    """Read a case (and optionally a reconstruction), write the PNG sheet atomically."""
    out = Path(output)
    if out.suffix.lower() != ".png":
        raise NaseviewError(f"{out}: the contact sheet is a PNG; give -o NAME.png")
    case = read_case(case_dir)
    rec = _load_reconstruction(Path(reconstruction)) if reconstruction is not None else None
    ok, buf = cv2.imencode(".png", contact_sheet(case, rec, tile))
    if not ok:
        raise NaseviewError(f"{out}: could not encode the PNG")
    return atomic_write_bytes(out, buf.tobytes())


def sheet_command(args: argparse.Namespace) -> int:
    """``naseview sheet CASE_DIR -o sheet.png [--reconstruction R]``."""
    path = write_sheet(args.case_dir, args.output, getattr(args, "reconstruction", None))
    print(path)
    return 0
