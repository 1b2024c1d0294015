"""Issue 26, item 1: two "Reconstruct" presses for the same new id at the same moment
(two tabs, two servers) never replace a patient: one case is written, the other press is
refused in one line ("patient P777 exists") and keeps its photos and clicks."""

from __future__ import annotations

import threading
from pathlib import Path

import numpy as np
from helpers import png_bytes

from naseview.case import read_case
from naseview.errors import NaseviewError
from naseview.fileio import read_json
from naseview.intake.click_order import CLICK_ORDER, VIEW_ORDER
from naseview.intake.patients import PatientFolders
from naseview.intake.session import AnnotationSession

SIZE = 64
TRIALS = 50


def _ready(s: AnnotationSession, shade: int) -> None:
    """Four photos (grey ``shade``) and enough clicks for a case."""
    img = np.full((SIZE, SIZE, 3), shade, np.uint8)
    for v in VIEW_ORDER:
        s.add_photo(v, png_bytes(img))
        for k, lid in enumerate(CLICK_ORDER[v][:8]):
            s.place(v, lid, (4.0 + 6 * k, 5.0 + 5 * k))
    s.set_scale("al_l", "al_r", 33.0)
    assert s.problems() == []


def test_two_reconstruct_presses_for_one_new_id_never_replace_a_patient(tmp_path: Path):
    work = PatientFolders(tmp_path / "work")
    a, b = work.new_session(), work.new_session()
    _ready(a, 90)
    _ready(b, 210)
    replaced = both_ok = 0
    for trial in range(TRIALS):
        cid = f"P777-{trial}"
        a.set_case_id(cid)                   # both typed the id at the same moment
        b.set_case_id(cid)
        out = work.case_dir(cid)
        barrier = threading.Barrier(2)
        results: dict[str, object] = {}

        def press(name: str, s: AnnotationSession, barrier=barrier, results=results,
                  out=out) -> None:
            barrier.wait()
            try:
                s.write_case(out)
                results[name] = "ok"
            except NaseviewError as e:
                results[name] = e

        threads = [threading.Thread(target=press, args=(n, s)) for n, s in (("a", a), ("b", b))]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        winners = [n for n, r in results.items() if r == "ok"]
        if len(winners) != 1:
            both_ok += len(winners) == 2
            replaced += 1
            continue
        loser = "b" if winners == ["a"] else "a"
        err = str(results[loser])
        assert "\n" not in err and f"patient {cid} exists" in err, err
        ann = read_json(out / "case.json")["annotation"]
        win = a if winners == ["a"] else b
        if ann["session"] != win.uid:
            replaced += 1
        shade = 90 if win is a else 210
        assert read_case(out).load_image("front")[0, 0, 0] == shade
        assert sorted(p.name for p in out.parent.iterdir()) == ["case"]   # no leftovers
    assert replaced == 0, f"{replaced}/{TRIALS} replaced patients ({both_ok} both 'saved')"
    for s in (a, b):                          # the clicks of both are kept
        again = AnnotationSession.open(s.folder)
        assert again.problems() == [] and again.progress("front") == s.progress("front")
