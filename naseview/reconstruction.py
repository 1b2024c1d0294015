"""The reconstruction result (SPEC §5) and its ``reconstruction.json``.

Each stage fills part of a :class:`Reconstruction`: stage 1 the landmarks and cameras,
stage 2 the curves and ad-landmarks, stage 3 the meshes and measurements. Synthetic ground
truth (``truth.json``, SPEC §7) uses the same schema.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from naseview.camera import Camera
from naseview.errors import NaseviewError
from naseview.fileio import atomic_write_json, read_json

RECONSTRUCTION_FORMAT = "naseview.reconstruction/1"


@dataclass
class Reconstruction:
    """Everything naseview knows about one nose, in the SPEC frame (mm).

    Attributes:
        landmarks: id -> (3,) position (mm), the 21 landmarks that could be placed.
        cameras: view -> :class:`~naseview.camera.Camera`.
        curves: curve name (SPEC §5) -> (N, 3) polyline (mm).
        ad_landmarks: (M, 3) the ad-landmarks (21 landmarks + sub-landmarks).
        ad_landmark_tags: M dicts ``{"curve", "t", "id"}`` describing each ad-landmark.
        reprojection_rmse_px: RMS reprojection error of the clicks.
        measurements: name -> value (mm or degrees).
        extra: further keys written verbatim (diagnostics, per-landmark uncertainty...).
    """

    landmarks: dict[str, np.ndarray] = field(default_factory=dict)
    cameras: dict[str, Camera] = field(default_factory=dict)
    curves: dict[str, np.ndarray] = field(default_factory=dict)
    ad_landmarks: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    ad_landmark_tags: list[dict[str, Any]] = field(default_factory=list)
    reprojection_rmse_px: float | None = None
    measurements: dict[str, float] = field(default_factory=dict)
    extra: dict[str, Any] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        """The ``reconstruction.json`` object: the SPEC §5 keys, then :attr:`extra`."""
        out: dict[str, Any] = {
            "format": RECONSTRUCTION_FORMAT,
            "units": "mm",
            "landmarks": {k: np.asarray(v, dtype=float).tolist()
                          for k, v in self.landmarks.items()},
            "curves": {k: np.asarray(v, dtype=float).reshape(-1, 3).tolist()
                       for k, v in self.curves.items()},
            "ad_landmarks": np.asarray(self.ad_landmarks, dtype=float).reshape(-1, 3).tolist(),
            "ad_landmark_tags": self.ad_landmark_tags,
            "cameras": {k: c.to_json() for k, c in self.cameras.items()},
            "reprojection_rmse_px": self.reprojection_rmse_px,
            "measurements": {k: float(v) for k, v in self.measurements.items()},
        }
        out.update(self.extra)
        return out

    @staticmethod
    def from_json(obj: dict[str, Any], where: str = "reconstruction.json") -> Reconstruction:
        """Parse a ``reconstruction.json`` object; keys beyond SPEC §5 land in ``extra``.

        Raises:
            NaseviewError: wrong ``format`` or malformed points, naming ``where``.
        """
        fmt = obj.get("format")
        if fmt != RECONSTRUCTION_FORMAT:
            raise NaseviewError(f"{where}: key 'format': expected {RECONSTRUCTION_FORMAT!r}, "
                                f"found {fmt!r}")
        try:
            landmarks = {k: np.asarray(v, dtype=np.float64).reshape(3)
                         for k, v in obj.get("landmarks", {}).items()}
            curves = {k: np.asarray(v, dtype=np.float64).reshape(-1, 3)
                      for k, v in obj.get("curves", {}).items()}
            ad = np.asarray(obj.get("ad_landmarks", []), dtype=np.float64).reshape(-1, 3)
        except (TypeError, ValueError):
            raise NaseviewError(f"{where}: landmarks, curves and ad_landmarks must hold "
                                "[x, y, z] numbers") from None
        cameras = {k: Camera.from_json(c, f"{where}: cameras.{k}")
                   for k, c in obj.get("cameras", {}).items()}
        known = {"format", "units", "landmarks", "curves", "ad_landmarks", "ad_landmark_tags",
                 "cameras", "reprojection_rmse_px", "measurements"}
        return Reconstruction(
            landmarks=landmarks, cameras=cameras, curves=curves, ad_landmarks=ad,
            ad_landmark_tags=list(obj.get("ad_landmark_tags", [])),
            reprojection_rmse_px=obj.get("reprojection_rmse_px"),
            measurements={k: float(v) for k, v in obj.get("measurements", {}).items()},
            extra={k: v for k, v in obj.items() if k not in known},
        )


def write_reconstruction(rec: Reconstruction, path: str | os.PathLike[str]) -> Path:
    """Write ``rec`` as JSON atomically."""
    return atomic_write_json(path, rec.to_json())


def read_reconstruction(path: str | os.PathLike[str]) -> Reconstruction:
    """Read a ``reconstruction.json`` or ``truth.json``."""
    path = Path(path)
    return Reconstruction.from_json(read_json(path), str(path))
