"""Helpers shared by the tests (the one shared test-helper module; test modules never
import each other)."""

from __future__ import annotations

import functools
import importlib.util
import math
import os
import shutil
import signal
import struct
import subprocess
import sys
import tempfile
import time
import zlib
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest
import setup_cache

from naseview.app.viewer import DEFAULT_VIEW, view_pose
from naseview.camera import Camera, look_at
from naseview.case import Case, View, write_case
from naseview.editing.baseline import Baseline, Solved, baseline_from_face_model
from naseview.editing.controller import EditController
from naseview.facemodel import FaceModel, load_face_model
from naseview.landmarks import LANDMARK_IDS, TABLE1_DISTANCES
from naseview.measurements import clinical_measurements
from naseview.reconstruction import Reconstruction, write_reconstruction
from naseview.stage1_landmarks import anatomical_frame
from naseview.testbed.evaluate import landmark_rmse_case


def wait_for(cond: Callable[[], object], timeout: float, what: str) -> None:
    """Poll ``cond`` every 20 ms until it is truthy; fail naming ``what`` after ``timeout`` s."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if cond():
            return
        time.sleep(0.02)
    raise AssertionError(f"timed out waiting for {what}")


REPO = Path(__file__).resolve().parents[1]


def wait_for_placed_camera(client: Any, baseline: Baseline, timeout: float = 30.0) -> None:
    """Wait until a tab's camera (``viser.ClientHandle``) reports the view the app places
    on a new tab (:data:`naseview.app.viewer.DEFAULT_VIEW` of ``baseline``): target and
    eye both within 1 mm, and a canvas size. A tab's first reports can carry the placed
    target with viser's default eye (3, 3, 3): a test projecting a landmark through that
    camera would click beside it."""
    target, eye, _, _ = view_pose(baseline.V, baseline.nose_ids, DEFAULT_VIEW)

    def placed() -> bool:
        cam = client.camera
        return bool(np.linalg.norm(np.asarray(cam.look_at) - target) < 1.0
                    and np.linalg.norm(np.asarray(cam.position) - eye) < 1.0
                    and cam.image_width > 0)

    wait_for(placed, timeout, "the tab's camera on the nose")


@contextmanager
def naseview_serve(args: list[str], env: Mapping[str, str] | None = None
                   ) -> Iterator[list[str]]:
    """``python -m naseview serve ARGS`` in a subprocess (from the repository, environment
    ``os.environ`` + ``env``; its texture bakes through the tests' cache,
    :func:`setup_cache.subprocess_env`), read until it says it is ready ("press Ctrl-C");
    yields its output lines so far (the server still running), then stops it with Ctrl-C
    (SIGINT), reading the rest of its output so it never blocks on a full pipe, and
    asserts a clean exit 0."""
    proc = subprocess.Popen([sys.executable, "-m", "naseview", "serve", *args], cwd=REPO,
                            env={**os.environ, "PYTHONUNBUFFERED": "1",
                                 **setup_cache.subprocess_env(), **(env or {})},
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    lines: list[str] = []
    try:
        assert proc.stdout is not None
        for line in proc.stdout:
            lines.append(line)
            if "press Ctrl-C" in line:
                break
        assert proc.poll() is None, "".join(lines)
        yield lines
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            lines.append(proc.communicate(timeout=90)[0] or "")
        finally:
            if proc.poll() is None:
                proc.kill()
    assert proc.returncode == 0, "".join(lines)


def open_tab(server: Any, app: Any, path: str = "/", timeout: float = 30.0
             ) -> tuple[Any, Any]:
    """A headless browser tab on ``server`` (:class:`naseview.app.headless_tab.HeadlessTab`)
    and its :class:`~naseview.app.screen.Screen` in ``app``, once built (with its scene
    when a case is open)."""
    from naseview.app.headless_tab import HeadlessTab

    tab = HeadlessTab(server, path)
    wait_for(lambda: (s := app.screen_of(tab.client)) is not None
             and (app.controller is None or s.shown.is_set()), timeout, "the tab's screen")
    return tab, app.screen_of(tab.client)


def project_to_view(camera: Any, X: np.ndarray) -> np.ndarray:
    """Pixel (x, y) of world point X (3,) in a client's viewport (viser's OpenCV camera:
    ``wxyz`` camera to world, vertical ``fov``)."""
    from viser import transforms as vtf

    R = vtf.SO3(np.asarray(camera.wxyz)).as_matrix()            # camera -> world
    pc = R.T @ (np.asarray(X, float) - np.asarray(camera.position))
    h, w = camera.image_height, camera.image_width
    f = (h / 2.0) / np.tan(camera.fov / 2.0)
    return np.array([w / 2.0 + f * pc[0] / pc[2], h / 2.0 + f * pc[1] / pc[2]])


CHROMIUM = "/usr/bin/chromium"
CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--enable-unsafe-swiftshader",
                  "--disable-background-networking"]


def browser_or_skip() -> None:
    """Check Playwright and Chromium for a browser test: skip without them on a
    developer's machine, fail when ``CI=true`` (CI must run every browser test)."""
    missing = ("playwright" if importlib.util.find_spec("playwright") is None
               else CHROMIUM if not Path(CHROMIUM).exists() else None)
    if missing is None:
        return
    if os.environ.get("CI", "").lower() == "true":
        pytest.fail(f"{missing} is missing; CI must run the browser tests")
    pytest.skip(f"{missing} is missing")


def bomb_png(width: int, height: int) -> bytes:
    """A decompression bomb: a small, valid PNG header declaring ``width`` x ``height``
    RGB pixels, with 64 rows of zeros as its data (a few hundred KB at most)."""
    def chunk(kind: bytes, data: bytes) -> bytes:
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    rows = (b"\x00" * (1 + 3 * width)) * 64
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(rows, 9))
            + chunk(b"IEND", b""))


def png_bytes(image_bgr: np.ndarray) -> bytes:
    """PNG file content of an (H, W, 3) uint8 BGR image."""
    return cv2.imencode(".png", image_bgr)[1].tobytes()


@functools.cache
def _ict_model() -> FaceModel:
    """The ICT Face Model Light, loaded once per test process (~2 s)."""
    assert os.environ.get("NASEVIEW_ICT_MODEL"), "conftest sets NASEVIEW_ICT_MODEL"
    return load_face_model("ict")


@functools.cache
def demo_output_dir() -> Path:
    """The bundled demo case reconstructed by ``naseview reconstruct`` (default face
    model), made once per version of the code and shared by every test process (xdist's
    workers too: :mod:`setup_cache`). Read only: a test writes nothing into it (its
    face.ply and nose.ply are checked against the SHA-256 in reconstruction.json when
    read)."""
    assert os.environ.get("NASEVIEW_ICT_MODEL"), "conftest sets NASEVIEW_ICT_MODEL"
    cache = setup_cache.cache_dir()
    done = cache / "demo-output"
    with setup_cache.file_lock(cache / "demo-output.lock"):
        if not (done / "out" / "reconstruction.json").is_file():
            work = Path(tempfile.mkdtemp(prefix="demo-output-", dir=cache))
            subprocess.run([sys.executable, "-m", "naseview", "reconstruct",
                            str(REPO / "assets" / "demo-case"), "-o", str(work / "out")],
                           check=True, capture_output=True, cwd=REPO)
            shutil.rmtree(done, ignore_errors=True)
            work.rename(done)      # same depth: the stored relative case_dir stays right
    return done / "out"


def ict_baseline() -> Baseline:
    """The ICT mean face as a reconstruction in the SPEC frame (origin at g)."""
    return baseline_from_face_model(_ict_model())


class GaussianSolver:
    """Test-only deformation: each nose vertex moves by the Gaussian-weighted (sigma
    6 mm) sum of the landmark displacements, and forwards (+z) by 0.1 x the sum of the
    manoeuvre amounts (recorded in ``manoeuvres_seen``); optional delay and failure
    trigger."""

    def __init__(self, baseline: Baseline, delay: float = 0.0,
                 fail_if: str | None = None) -> None:
        self.b = baseline
        self.delay = delay
        self.fail_if = fail_if
        self.calls = 0
        self.manoeuvres_seen: list[dict[str, float]] = []

    def __call__(self, landmarks: Mapping[str, np.ndarray],
                 interactive: bool = False,
                 manoeuvres: Mapping[str, float] | None = None) -> Solved:
        self.calls += 1
        self.manoeuvres_seen.append(dict(manoeuvres or {}))
        if self.delay:
            time.sleep(self.delay)
        b = self.b
        V = b.V.copy()
        P = V[b.nose_ids]
        for k, p in landmarks.items():
            d = np.asarray(p) - b.landmarks[k]
            if np.any(d):
                if k == self.fail_if:
                    raise RuntimeError("solver exploded (test)")
                w = np.exp(-np.sum((b.V[b.nose_ids] - b.landmarks[k]) ** 2, 1) / 72.0)
                P = P + w[:, None] * d
        if manoeuvres:
            P = P + np.array([0.0, 0.0, 0.1 * sum(manoeuvres.values())])
        V[b.nose_ids] = P
        curves = {n: c + 0.0 for n, c in b.curves.items()}
        return Solved(V, curves, b.ad_landmarks.copy(),
                      clinical_measurements(landmarks, curves, V, b.F))


def drag(ctl: EditController, lid: str, delta: np.ndarray, steps: int = 5) -> None:
    """A drag as the browser sends it: start, several updates, end."""
    start = ctl.landmarks[lid]
    ctl.begin_drag(lid)
    for s in range(1, steps + 1):
        ctl.drag_to(lid, start + delta * s / steps)
    ctl.end_drag()


def landmarks_close(a: Mapping[str, np.ndarray], b: Mapping[str, np.ndarray]) -> bool:
    """Same ids at bit-identical positions."""
    return a.keys() == b.keys() and all(np.array_equal(a[k], b[k]) for k in a)


# Stage 1 ground truth by projection (moved from tests/test_sfm.py): known 3D landmarks
# through known cameras, no rendering. A plausible adult nose (mm, SPEC frame, origin g);
# ground truth is drawn around it.
BASE_NOSE = {
    "g": (0.0, 0.0, 0.0), "n": (0.0, -13.0, -7.0), "k": (0.0, -25.0, -2.0),
    "r": (0.0, -32.0, 2.0), "prn": (0.0, -46.0, 15.0), "c": (0.0, -52.0, 10.0),
    "sn": (0.0, -58.0, -2.0),
    "mf_l": (10.0, -11.0, -12.0), "int_l": (10.0, -39.0, 0.0), "al_l": (16.5, -47.0, -5.0),
    "alp_l": (8.0, -51.0, 6.0), "alpp_l": (5.5, -54.0, 2.0), "ac_l": (14.0, -51.0, -9.0),
    "md_l": (6.5, -50.0, 8.5),
}

# Landmarks clicked per photo (alpp also in the front photo, where nostrils show).
VISIBLE = {
    "front": [i for i in LANDMARK_IDS],
    "left": ["g", "n", "k", "r", "prn", "c", "sn", "mf_l", "int_l", "al_l", "ac_l", "alp_l",
             "md_l"],
    "right": ["g", "n", "k", "r", "prn", "c", "sn", "mf_r", "int_r", "al_r", "ac_r", "alp_r",
              "md_r"],
    "bottom": ["prn", "c", "sn", "al_l", "al_r", "alp_l", "alp_r", "alpp_l", "alpp_r", "ac_l",
               "ac_r", "md_l", "md_r"],
}


def random_nose(rng: np.random.Generator) -> dict[str, np.ndarray]:
    """A random nose: BASE_NOSE scaled per axis, symmetric offsets, slight asymmetry (mm)."""
    scale = rng.uniform(0.85, 1.15, 3)
    out: dict[str, np.ndarray] = {}
    for lid, p in BASE_NOSE.items():
        off = rng.normal(0, 1.5, 3)
        q = np.array(p) * scale + off
        if lid.endswith("_l"):
            out[lid] = q
            out[lid[:-2] + "_r"] = q * [-1, 1, 1] + rng.normal(0, 0.5, 3)
        else:
            q[0] = rng.normal(0, 0.4)
            out[lid] = q
    g = out["g"].copy()
    return {k: v - g for k, v in out.items()}


def _rot(axis: np.ndarray, deg: float) -> np.ndarray:
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    a = math.radians(deg)
    return np.eye(3) + math.sin(a) * k + (1 - math.cos(a)) * k @ k


def rig_cameras(rng: np.random.Generator, size: int = 1024, jitter_deg: float = 8.0,
                offsets: dict[str, tuple[float, float]] | None = None,
                focal: float | None = None) -> dict[str, Camera]:
    """Four cameras around a nose at g-origin: nominal rig + random or given offsets.

    ``offsets``: view -> (yaw, pitch) degrees added to the nominal direction (else random
    with ``jitter_deg`` standard deviation); roll is always random (+-10 deg).
    """
    nominal = {"front": (0.0, 0.0), "left": (90.0, 0.0), "right": (-90.0, 0.0),
               "bottom": (0.0, -50.0)}
    target = np.array([0.0, -35.0, 0.0])
    cams = {}
    for v, (yaw, pitch) in nominal.items():
        dy, dp = offsets[v] if offsets and v in offsets else rng.normal(0, jitter_deg, 2)
        y, p = math.radians(yaw + dy), math.radians(pitch + dp)
        direction = np.array([math.sin(y) * math.cos(p), math.sin(p), math.cos(y) * math.cos(p)])
        dist = rng.uniform(350, 700)
        f = focal if focal is not None else dist * rng.uniform(4.0, 6.0)
        up = np.array([0.0, 1.0, 0.0]) if abs(p) < math.radians(70) else np.array([0, 0, 1.0])
        cam = look_at(target + dist * direction + rng.normal(0, 5, 3), target, up, f, size, size)
        roll = _rot([0, 0, 1], rng.uniform(-10, 10))
        cams[v] = Camera(cam.K, roll @ cam.R, roll @ cam.t, size, size)
    return cams


def project_case(truth: dict[str, np.ndarray], cams: dict[str, Camera],
                 rng: np.random.Generator, noise_px: float, root: Path,
                 visible: dict[str, list[str]] | None = None) -> Case:
    """In-memory Case of noisy projected clicks; scale from the true al_l-al_r."""
    visible = visible or VISIBLE
    views = {}
    for v, cam in cams.items():
        ids = [i for i in visible[v] if i in truth]
        uv = cam.project(np.array([truth[i] for i in ids]))
        uv = uv + rng.normal(0, noise_px, uv.shape) if noise_px > 0 else uv
        views[v] = View(v, f"{v}.png", {i: uv[k] for k, i in enumerate(ids)}, cam.width,
                        cam.height)
    d = float(np.linalg.norm(truth["al_l"] - truth["al_r"]))
    return Case(root=root, id="synthetic", views=views, scale_mm={("al_l", "al_r"): d})


def write_projected_case(out: Path, seed: int, noise_px: float = 1.5, size: int = 1024
                         ) -> Path:
    """A case directory with blank photos and truth.json (SPEC §7) from projections."""
    rng = np.random.default_rng(seed)
    truth = random_nose(rng)
    cams = rig_cameras(rng, size)
    case = project_case(truth, cams, rng, noise_px, out)
    blank = np.full((size, size, 3), 128, np.uint8)
    write_case(case, out, images={v: blank for v in case.views})
    write_reconstruction(Reconstruction(landmarks=truth, cameras=cams), out / "truth.json")
    return out


def kabsch_errors(pred: dict[str, np.ndarray], truth: dict[str, np.ndarray]) -> np.ndarray:
    """Per-landmark distances (mm) after the best rigid alignment of pred onto truth."""
    per = landmark_rmse_case(pred, truth)["per_landmark_mm"]
    return np.array([per[i] for i in pred if i in truth])


def table1_errors(pred: dict[str, np.ndarray], truth: dict[str, np.ndarray]) -> np.ndarray:
    """|predicted - true| (mm) of each paper Table 1 distance."""
    return np.array([abs(np.linalg.norm(pred[a] - pred[b]) - np.linalg.norm(truth[a] - truth[b]))
                     for a, b in TABLE1_DISTANCES])


def make_case(seed: int, noise_px: float = 1.5, **kw) -> tuple[Case, dict[str, np.ndarray]]:
    """An in-memory projected case of a random nose (seed) and its truth."""
    rng = np.random.default_rng(seed)
    truth = random_nose(rng)
    cams = rig_cameras(rng, **kw)
    return project_case(truth, cams, rng, noise_px, Path("/nonexistent")), truth


def gauge_truth(truth: dict[str, np.ndarray], ids: list[str]) -> dict[str, np.ndarray]:
    """Truth in the anatomical frame defined by ``ids`` (what the estimate's frame means)."""
    o, R = anatomical_frame({k: truth[k] for k in ids})
    return {k: R @ (truth[k] - o) for k in truth}
