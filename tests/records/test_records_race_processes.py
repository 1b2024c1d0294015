"""Issue 26 item 2 with two real OS processes: two servers on one work folder open one
simulation, edit it and save at the same instant (``sim_race``). A save reported done is
on disk; the other server is told in one line; never both "saved" with one edit missing."""

from __future__ import annotations

from pathlib import Path

from records_fixtures import Patient
from sim_race import RaceServer, race_round

ROUNDS = 12


def test_two_server_processes_saving_one_simulation_at_once_lose_nothing(patient: Patient):
    slug = patient.first_simulation()
    work: Path = patient.records.folders.root
    servers = [RaceServer(), RaceServer()]
    try:
        results = [race_round(servers, work, patient.pid, slug, trial)
                   for trial in range(ROUNDS)]
    finally:
        for s in servers:
            s.close()
    lost = sum(r.lost for r in results)
    assert not any(r.corrupt for r in results)
    assert lost == 0, f"{lost}/{ROUNDS} saves reported done were lost"
    for r in results:     # one wins; the other was told, in one line
        assert (r.saved, r.told) == (1, 1), r.messages
