"""Fault injection on the patients' records (issue 26): processes killed (SIGKILL) at
random moments of autosave, reconstruction and case writes; stop signals (SIGTERM,
SIGHUP, SIGINT) on ``naseview serve``; three tabs of one server editing one simulation at
once, killed at random moments; two server processes (``tests/records/sim_race.py``)
saving one simulation at the same instant, the loser told.

Each kill is a forked child (the imports are paid once) working on its own copy of a
small patient; after the kill the folder is read back as the next start would:

- *lost*: a save the child reported as done (flush returned without an error, or a
  write returned) that is not on disk; of two servers, a loser that was not told;
- *corrupt*: a file that does not parse, a reconstruction set that cannot be read, a case
  that ``read_case`` refuses.

    python benchmarks/bench_faults.py            # 200 kills, prints the table
    python benchmarks/bench_faults.py --kills 40 --seed 3
"""

from __future__ import annotations

import argparse
import logging
import os
import random
import shutil
import signal
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests"), str(ROOT / "tests" / "records"),
                str(ROOT / "tests" / "intake")]

import numpy as np  # noqa: E402
from helpers import drag, png_bytes  # noqa: E402
from records_fixtures import Patient, grid_result, write_case_json  # noqa: E402
from sim_race import RaceServer, race_round  # noqa: E402

import naseview.app.serve as serve  # noqa: E402
from naseview.case import read_case  # noqa: E402
from naseview.editing.baseline import baseline_from_pipeline  # noqa: E402
from naseview.editing.controller import EditController  # noqa: E402
from naseview.errors import NaseviewError  # noqa: E402
from naseview.intake.click_order import CLICK_ORDER, VIEW_ORDER  # noqa: E402
from naseview.intake.patients import PatientFolders  # noqa: E402
from naseview.intake.session import AnnotationSession  # noqa: E402
from naseview.records import PatientRecords  # noqa: E402
from naseview.records.autosave import Autosave  # noqa: E402
from naseview.records.patient import reconstruction_state  # noqa: E402
from naseview.records.simulations import read_simulation  # noqa: E402

PID = "P001"


def _patient(work: Path) -> Patient:
    records = PatientRecords(work)
    case = write_case_json(records.folders.case_dir(PID), PID)
    result = grid_result(case)
    saved = records.save_reconstruction(PID, result)
    return Patient(records, PID, saved, baseline_from_pipeline(result))


def _report(fd: int, text: str) -> None:
    os.write(fd, (text + "\n").encode())


def _run_killed(child: Callable[[int], None], kill_after: float,
                sig: int = signal.SIGKILL, wait_line: str | None = None) -> list[str]:
    """Fork ``child(write_fd)``; send ``sig`` after ``kill_after`` s (after the line
    ``wait_line`` when given); the lines the child reported before it died."""
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:  # pragma: no cover - the child
        os.close(r)
        try:
            child(w)
        finally:
            os._exit(0)
    os.close(w)
    buf = b""
    if wait_line is not None:
        while wait_line.encode() not in buf:
            chunk = os.read(r, 4096)
            if not chunk:
                break
            buf += chunk
    time.sleep(kill_after)
    os.kill(pid, sig)
    while True:
        chunk = os.read(r, 4096)
        if not chunk:
            break
        buf += chunk
    os.close(r)
    os.waitpid(pid, 0)
    return buf.decode().splitlines()


def _patient_simulation(work: Path) -> tuple[Patient, str]:
    """A fresh patient and a first simulation of it (no edit): (patient, its slug)."""
    p = _patient(work)
    return p, p.first_simulation()


def _resume(work: Path, slug: str, delay: float) -> tuple[EditController, Autosave]:
    """The simulation ``slug`` opened in a new window of its own (records, controller,
    autosave after ``delay`` s), as another tab or server would."""
    rec = PatientRecords(work)
    s = rec.load_simulation(PID, slug)
    ctl = EditController.from_session(s, None)
    return ctl, rec.resume_simulation(PID, slug, ctl, s, delay=delay)


# scenarios: each returns (lost, corrupt) of one kill

def autosave_kill(work: Path, rng: random.Random) -> tuple[int, int]:
    p, slug = _patient_simulation(work)

    def child(w: int) -> None:
        ctl, auto = _resume(work, slug, rng.choice([0.0, 0.01, 0.05]))
        for n in range(1, 10_000):
            drag(ctl, "prn", np.array([0.0, 0.0, 0.01]), steps=1)
            if auto.flush() and auto.error is None:
                _report(w, f"saved {n}")

    lines = _run_killed(child, rng.uniform(0.02, 0.4))
    done = max((int(x.split()[1]) for x in lines if x.startswith("saved")), default=0)
    try:
        s = read_simulation(p.records.folders, PID, slug)
    except NaseviewError:
        return 0, 1
    z0 = p.baseline.landmarks["prn"][2]
    on_disk = round((s.landmarks["prn"][2] - z0) / 0.01)
    return int(on_disk < done), 0


def reconstruction_kill(work: Path, rng: random.Random) -> tuple[int, int]:
    p = _patient(work)
    case = p.records.folders.case_dir(PID)

    def child(w: int) -> None:
        rec = PatientRecords(work)
        for n in range(1, 10_000):
            saved = rec.save_reconstruction(PID, grid_result(case, lift=float(n)))
            _report(w, f"saved {saved.sha256}")

    lines = _run_killed(child, rng.uniform(0.0, 0.3))
    shas = [x.split()[1] for x in lines if x.startswith("saved")]
    state = reconstruction_state(p.records.folders, PID)
    if state.problem is not None or state.folder is None:
        return 0, 1
    # the current set is the last one reported, or the one being written after it
    lost = int(bool(shas) and state.sha256 in shas[:-1])
    return lost, 0


def _ready(s: AnnotationSession, shade: int) -> None:
    img = np.full((64, 64, 3), shade, np.uint8)
    for v in VIEW_ORDER:
        s.add_photo(v, png_bytes(img))
        for k, lid in enumerate(CLICK_ORDER[v][:8]):
            s.place(v, lid, (4.0 + 6 * k, 5.0 + 5 * k))
    s.set_scale("al_l", "al_r", 33.0)


def case_kill(work: Path, rng: random.Random) -> tuple[int, int]:
    folders = PatientFolders(work)
    s = folders.new_session("P900")
    _ready(s, 100)
    out = folders.case_dir("P900")
    s.write_case(out)

    def child(w: int) -> None:
        for n in range(1, 10_000):
            s.place("front", "g", (5.0 + n % 40, 6.0))
            s.write_case(out)
            _report(w, f"saved {n}")

    lines = _run_killed(child, rng.uniform(0.0, 0.3))
    done = [int(x.split()[1]) for x in lines if x.startswith("saved")]
    try:
        case = read_case(out)
    except NaseviewError:
        return 0, 1
    g = float(case.views["front"].landmarks["g"][0])
    ok = {5.0 + n % 40 for n in done[-1:]} | {5.0 + (done[-1] + 1) % 40 if done else 0.0}
    return int(bool(done) and g not in ok), 0


def signal_stop(work: Path, rng: random.Random, sig: int) -> tuple[int, int]:
    p, slug = _patient_simulation(work)

    def child(w: int) -> None:
        ctl, auto = _resume(work, slug, 60.0)              # pending until close
        drag(ctl, "prn", np.array([0.0, 0.0, 1.0]), steps=1)

        class App:
            source = None
            controller = None

            def wait_ready(self, timeout: float) -> bool:
                return True

            def close(self) -> None:
                auto.close()

        class Server:
            def get_port(self) -> int:
                return 1

            def stop(self) -> None:
                pass

        serve.start_app = lambda *a, **k: (Server(), App())  # type: ignore[assignment]
        os.dup2(w, 1)
        serve.serve_command(argparse.Namespace(path=None, host="127.0.0.1", port=0,
                                               no_browser=True))

    _run_killed(child, rng.uniform(0.0, 0.2), sig, wait_line="press Ctrl-C")
    try:
        s = read_simulation(p.records.folders, PID, slug)
    except NaseviewError:
        return 0, 1
    moved = s.landmarks["prn"][2] - p.baseline.landmarks["prn"][2]
    return int(abs(moved - 1.0) > 1e-6), 0


def three_tabs_kill(work: Path, rng: random.Random) -> tuple[int, int]:
    """Three tabs of one server (one controller, one autosave, as the app shares them)
    edit one simulation at once, each its own landmark, each waiting for its save; the
    server is killed at a random moment. Lost: a tab told its edit ``n`` was saved whose
    landmark is behind ``n`` on disk."""
    p, slug = _patient_simulation(work)
    tabs = ("prn", "al_l", "al_r")

    def child(w: int) -> None:
        ctl, auto = _resume(work, slug, rng.choice([0.0, 0.01, 0.05]))
        lock = threading.Lock()

        def tab(lid: str) -> None:
            for n in range(1, 10_000):
                ctl.move_landmarks({lid: ctl.landmarks[lid] + np.array([0.0, 0.0, 0.01])})
                if auto.flush() and auto.error is None:
                    with lock:
                        _report(w, f"saved {lid} {n}")

        threads = [threading.Thread(target=tab, args=(lid,), daemon=True) for lid in tabs]
        for t in threads:
            t.start()
        for t in threads:
            t.join()

    lines = _run_killed(child, rng.uniform(0.02, 0.4))
    done = {lid: 0 for lid in tabs}
    for x in lines:
        if x.startswith("saved"):
            _, lid, n = x.split()
            done[lid] = max(done[lid], int(n))
    try:
        s = read_simulation(p.records.folders, PID, slug)
    except NaseviewError:
        return 0, 1
    lost = 0
    for lid in tabs:
        on_disk = round((s.landmarks[lid][2] - p.baseline.landmarks[lid][2]) / 0.01)
        lost += int(on_disk < done[lid])
    return lost, 0


_SERVERS: list[RaceServer] = []
"""The two server processes of the "two servers" row, up for all its races."""


def two_servers(work: Path, rng: random.Random) -> tuple[int, int]:
    """Two server processes (``sim_race``) open one simulation, edit it and save at
    the same instant: 1 race. Lost: a save reported done whose edit is not on disk, or a
    loser that was not told."""
    _, slug = _patient_simulation(work)
    if not _SERVERS:
        _SERVERS.extend([RaceServer(), RaceServer()])
    r = race_round(_SERVERS, work, PID, slug, rng.randrange(1000))
    return r.lost + (2 - r.saved - r.told), int(r.corrupt)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kills", type=int, default=200, help="SIGKILLs in all (default 200)")
    ap.add_argument("--signals", type=int, default=5, help="stops per signal (default 5)")
    ap.add_argument("--tabs", type=int, default=40,
                    help="SIGKILLs of a server with three tabs editing (default 40)")
    ap.add_argument("--races", type=int, default=50,
                    help="two-server-process races (default 50)")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args(argv)
    rng = random.Random(args.seed)
    logging.getLogger("naseview").setLevel(logging.ERROR)  # the losers' one-line warnings
    share = {"autosave": 0.4, "reconstruction": 0.35, "case write": 0.25}
    rows: list[tuple[str, Callable[[Path, random.Random], tuple[int, int]], int]] = [
        (name, fn, max(1, round(args.kills * share[name]))) for name, fn in (
            ("autosave", autosave_kill), ("reconstruction", reconstruction_kill),
            ("case write", case_kill))]
    for name in ("SIGTERM", "SIGHUP", "SIGINT"):
        sig = getattr(signal, name)
        rows.append((f"serve {name}", lambda w, r, sig=sig: signal_stop(w, r, sig),
                     args.signals))
    rows.append(("three tabs kill", three_tabs_kill, args.tabs))
    rows.append(("two servers", two_servers, args.races))
    print(f"{'fault':<16}{'runs':>6}{'survived':>10}{'lost':>6}{'corrupt':>9}{'s':>7}")
    total = [0, 0, 0, 0]
    for name, fn, n in rows:
        t0 = time.perf_counter()
        lost = corrupt = survived = 0
        for _ in range(n):
            work = Path(tempfile.mkdtemp(prefix="naseview-faults-"))
            try:
                dl, dc = fn(work / "work", rng)
            finally:
                shutil.rmtree(work, ignore_errors=True)
            lost += dl
            corrupt += dc
            survived += dl == 0 and dc == 0
        print(f"{name:<16}{n:>6}{survived:>10}{lost:>6}{corrupt:>9}"
              f"{time.perf_counter() - t0:>7.1f}", flush=True)
        for i, v in enumerate((n, survived, lost, corrupt)):
            total[i] += v
    for srv in _SERVERS:
        srv.close()
    print(f"{'total':<16}{total[0]:>6}{total[1]:>10}{total[2]:>6}{total[3]:>9}")
    return 0 if total[2] == 0 and total[3] == 0 else 1


if __name__ == "__main__":
    raise SystemExit(main())
