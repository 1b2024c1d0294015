"""Two naseview servers, as two OS processes, saving one simulation at the same moment
(issue 26 item 2): the race of ``tests/records/test_records_race_processes.py`` and of
``benchmarks/bench_faults.py``'s "two servers" row.

Each server is a ``python sim_race.py`` process that stays up for all the rounds and
runs the code paths the app runs when a surgeon opens a simulation and edits it
(:meth:`PatientRecords.load_simulation`, :meth:`EditController.from_session`,
:meth:`PatientRecords.resume_simulation`, an edit, the autosave's compare-and-swap). A
round, driven by :func:`race_round`: both servers open the simulation, each moves ``prn``
its own way, and both flush at one instant of the machine's monotonic clock (shared by
every process on Linux). Afterwards the file on disk is read back:

- *lost*: a server was told its save was done (no error) but its edit is not on disk;
- *told*: a server was refused in one line ("changed by another naseview window"),
  and kept its edit on screen;
- *corrupt*: the simulation file cannot be read.

Commands (one a line on the worker's stdin; answers on its stdout):
``open WORK PID SLUG DY DZ`` -> ``ready``; ``go T`` (flush at monotonic time T) -> ``saved`` or
``told <message>``; ``quit``.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]


@dataclass
class RoundResult:
    """What one round of the race left: saves reported done whose edit is missing,
    servers told they lost, saves done, and whether the file could not be read."""

    lost: int
    told: int
    saved: int
    corrupt: bool
    messages: list[str]


class RaceServer:
    """A worker process (one "server"); each round names its work folder."""

    def __init__(self) -> None:
        env = dict(os.environ, PYTHONPATH=os.pathsep.join(
            [str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])]))
        self.proc = subprocess.Popen(
            [sys.executable, __file__], stdin=subprocess.PIPE,
            stdout=subprocess.PIPE, text=True, bufsize=1, env=env, cwd=str(ROOT))

    def send(self, line: str) -> None:
        assert self.proc.stdin is not None
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()

    def answer(self) -> str:
        assert self.proc.stdout is not None
        line = self.proc.stdout.readline()
        if not line:
            raise RuntimeError(f"race worker exited (rc {self.proc.wait()})")
        return line.rstrip("\n")

    def close(self) -> None:
        try:
            self.send("quit")
            self.proc.wait(timeout=30)
        except (OSError, subprocess.TimeoutExpired):
            self.proc.kill()
            self.proc.wait()


def edit_of(k: int, trial: int) -> tuple[float, float]:
    """(dy, dz) mm by which server ``k`` moves ``prn`` in round ``trial``."""
    return 0.1 * (trial + 1), 0.3 * (k + 1)


def race_round(servers: list[RaceServer], work: Path, pid: str, slug: str,
               trial: int, lead: float = 0.05) -> RoundResult:
    """One round: every server opens ``slug`` and edits it, then all flush at once."""
    from naseview.errors import NaseviewError
    from naseview.intake.patients import PatientFolders
    from naseview.records.simulations import read_simulation

    folders = PatientFolders(work)
    start = read_simulation(folders, pid, slug).landmarks["prn"].copy()
    for k, s in enumerate(servers):
        dy, dz = edit_of(k, trial)
        s.send(f"open {work} {pid} {slug} {dy!r} {dz!r}")
    for s in servers:
        if (a := s.answer()) != "ready":
            raise RuntimeError(f"race worker: {a}")
    at = time.monotonic() + lead
    for s in servers:
        s.send(f"go {at!r}")
    answers = [s.answer() for s in servers]
    try:
        on_disk = read_simulation(folders, pid, slug).landmarks["prn"]
    except NaseviewError:
        return RoundResult(0, 0, 0, True, answers)
    lost = told = saved = 0
    for k, a in enumerate(answers):
        if a == "saved":
            saved += 1
            want = start + np.array([0.0, *edit_of(k, trial)])
            lost += int(not np.allclose(on_disk, want))
        elif a.startswith("told ") and "another naseview window" in a:
            told += 1
        else:
            raise RuntimeError(f"race worker: {a}")
    return RoundResult(lost, told, saved, False, answers)


def _worker() -> None:  # pragma: no cover - runs in the worker process
    import logging

    from naseview.editing.controller import EditController
    from naseview.records import PatientRecords

    logging.getLogger("naseview").setLevel(logging.CRITICAL)  # the loser's one line
    opened: list = []
    for line in sys.stdin:
        cmd, *args = line.split()
        if cmd == "quit":
            break
        if cmd == "open":
            work, pid, slug = Path(args[0]), args[1], args[2]
            dy, dz = float(args[3]), float(args[4])
            rec = PatientRecords(work)
            session = rec.load_simulation(pid, slug)
            ctl = EditController.from_session(session, None)
            auto = rec.resume_simulation(pid, slug, ctl, session, delay=60.0)
            ctl.move_landmarks({"prn": ctl.landmarks["prn"] + np.array([0.0, dy, dz])})
            opened = [rec, ctl, auto]
            print("ready", flush=True)
        elif cmd == "go":
            rec, ctl, auto = opened
            time.sleep(max(0.0, float(args[0]) - time.monotonic()))
            auto.flush()
            print("saved" if auto.error is None else f"told {auto.error}", flush=True)
            auto.close()            # the loser's close tries again and is refused again
            ctl.close()
            rec.close()
            opened = []


if __name__ == "__main__":  # pragma: no cover
    _worker()
