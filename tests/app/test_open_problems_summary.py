"""issue 26 item 10: opening a patient whose linked case moved summarises the problems of
its simulations in one short line (the count and the first), not one line of every one."""

from __future__ import annotations

from naseview.app.patient_work import summarise


def test_many_problems_are_one_short_line_with_count_and_first() -> None:
    problems = [f"/work/P001/simulations/sim-{i}.json: key 'app.case_dir': the case folder "
                "../case was moved; open the case folder again" for i in range(16)]
    assert len(" ".join(problems)) > 1500                # what serve WORK/P001 printed
    line = summarise(problems)
    assert line.startswith("16 problems; the first: /work/P001/simulations/sim-0.json")
    assert "sim-1.json" not in line and "\n" not in line and len(line) < 200


def test_one_problem_is_itself() -> None:
    assert summarise(["x.json: bad"]) == "x.json: bad" and summarise([]) == ""
