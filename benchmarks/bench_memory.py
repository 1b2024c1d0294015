"""Server memory over many tabs opened and closed (issue 26, item 13).

``naseview serve`` of the bundled demo case (the app the surgeon runs), then ``--cycles``
times: a tab opens (:class:`naseview.app.headless_tab.HeadlessTab`: the page's websocket,
its camera, every scene and GUI message read as a browser would), waits until the app has
built its screen, and closes. The server's resident memory (RSS, from /proc) is read after
the first 10 cycles and every ``--every`` cycles after, once Python's garbage collector has
run. A leak grows without bound; allocator and cache warm-up level off.

Target (issue 26): RSS after 100 cycles within 10 % of RSS after the first 10.

    python benchmarks/bench_memory.py [--cycles 100] [--every 10] [--tabs 1]
"""

from __future__ import annotations

import argparse
import gc
import os
import time
from pathlib import Path

from naseview.app.headless_tab import HeadlessTab
from naseview.app.naseview_app import demo_case_dir
from naseview.app.serve import start_app


def rss_mb() -> float:
    """Resident set size of this process, MB (Linux /proc)."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024.0
    return float("nan")


def cycle(server: object, app: object, tabs: int) -> None:
    """Open ``tabs`` tabs, wait for their screens, close them; wait until the server has
    dropped them."""
    opened = [HeadlessTab(server) for _ in range(tabs)]  # type: ignore[arg-type]
    end = time.monotonic() + 30
    while time.monotonic() < end:
        if all(app.screen_of(t.client) is not None for t in opened):  # type: ignore[attr-defined]
            break
        time.sleep(0.05)
    for t in opened:
        t.close()
    end = time.monotonic() + 30
    while server.get_clients() and time.monotonic() < end:  # type: ignore[attr-defined]
        time.sleep(0.05)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cycles", type=int, default=100)
    ap.add_argument("--every", type=int, default=10)
    ap.add_argument("--tabs", type=int, default=1, help="tabs opened together per cycle")
    args = ap.parse_args()
    os.environ.setdefault("NASEVIEW_WORK_DIR", "/tmp/naseview-bench-memory-work")
    server, app = start_app(demo_case_dir(), host="127.0.0.1", port=0, model="generic")
    assert app.wait_ready(300), "the demo case did not open"
    gc.collect()
    start = rss_mb()
    rows: list[tuple[int, float]] = []
    t0 = time.perf_counter()
    for i in range(1, args.cycles + 1):
        cycle(server, app, args.tabs)
        if i == 10 or (i > 10 and i % args.every == 0) or i == args.cycles:
            gc.collect()
            rows.append((i, rss_mb()))
    seconds = time.perf_counter() - t0
    app.close()
    server.stop()
    ref = dict(rows).get(10, rows[0][1])
    print(f"{'cycles':>7} {'RSS MB':>8} {'vs 10':>8}")
    print(f"{0:7d} {start:8.1f} {'':>8}")
    for i, r in rows:
        print(f"{i:7d} {r:8.1f} {100 * (r - ref) / ref:+7.1f}%")
    last = rows[-1][1]
    ok = abs(last - ref) <= 0.10 * ref
    print(f"{args.tabs} tab(s) per cycle, {seconds / args.cycles:.2f} s a cycle; after "
          f"{rows[-1][0]} cycles {100 * (last - ref) / ref:+.1f}% of after 10 "
          f"(target within 10 %): {'met' if ok else 'MISSED'}")


if __name__ == "__main__":
    main()
