"""Issue 26, item 5: SIGTERM and SIGHUP (``kill``, closing the terminal, logging out)
stop ``naseview serve`` like Ctrl-C: the app is closed, so the pending save is written,
and a second signal during that save does not cut it short."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

SCRIPT = textwrap.dedent("""
    import argparse, sys, time
    from pathlib import Path
    import naseview.app.serve as serve
    marker = Path(sys.argv[1])

    class FakeServer:
        def get_port(self): return 1
        def stop(self): pass

    class FakeApp:
        source = None
        controller = None
        def wait_ready(self, timeout): return True
        def close(self):                      # what PatientWork.close does: the flush
            marker.write_text("saving")
            time.sleep(0.5)
            marker.write_text("saved")

    serve.start_app = lambda *a, **k: (FakeServer(), FakeApp())
    rc = serve.serve_command(argparse.Namespace(path=None, host="127.0.0.1", port=0,
                                                no_browser=True))
    print("rc", rc, flush=True)
""")


@pytest.mark.parametrize("sig", ["SIGTERM", "SIGHUP", "SIGINT"])
def test_a_stop_signal_writes_the_pending_save(tmp_path: Path, sig: str):
    marker = tmp_path / "closed"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    p = subprocess.Popen([sys.executable, "-c", SCRIPT, str(marker)], env=env, cwd=ROOT,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert p.stdout is not None
        for line in p.stdout:
            if "press Ctrl-C" in line:
                break
        p.send_signal(getattr(signal, sig))
        if sig != "SIGINT":                    # a second one while saving
            end = time.monotonic() + 5
            while not marker.exists() and time.monotonic() < end:
                time.sleep(0.01)
            p.send_signal(getattr(signal, sig))
        out, err = p.communicate(timeout=20)
    finally:
        if p.poll() is None:
            p.kill()
    assert marker.read_text() == "saved", (out, err)
    assert p.returncode == 0 and "rc 0" in out, (p.returncode, out, err)
    assert "Traceback" not in err, err
