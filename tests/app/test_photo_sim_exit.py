"""Issue 26: no "terminate called without an active exception" (abort, exit status 134)
when the interpreter exits after the served app stopped while a tab's photo composite
(OpenCV, native code, a daemon worker) was still running: the workers are joined at exit
(``naseview.app.photo_sim.join_workers``)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

SCRIPT = """
import time
import cv2
import numpy as np
from naseview.app.photo_sim import PhotoSimulation

img = np.random.default_rng(0).integers(0, 255, (1500, 1500, 3), np.uint8)
started = []

def inputs(view):  # a composite: seconds of OpenCV with the GIL released
    started.append(view)
    for _ in range(25):
        cv2.GaussianBlur(img, (31, 31), 0)
    print("composite finished", flush=True)
    return None

sim = PhotoSimulation(inputs, ("front",))
sim.request("front")
while not started:
    time.sleep(0.01)
time.sleep(0.1)
sim.close()          # the tab went away; the server stopped; the interpreter exits now
print("closed", flush=True)
"""


def test_interpreter_exit_during_a_photo_composite_does_not_abort():
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    p = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True,
                       env=env, cwd=str(ROOT), timeout=120)
    assert "terminate called" not in p.stderr, p.stderr
    assert p.returncode == 0, (p.returncode, p.stderr)
    assert p.stdout.split() == ["closed", "composite", "finished"]  # waited for it
