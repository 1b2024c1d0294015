"""Drag-update latency and bytes per update of the app on the ICT face (server side).

A drag is replayed as the browser sends it: ``drag_to`` every 50 ms (viser throttles drag
events to ~20 Hz), through the app's real path (controller -> worker -> stage 3 solve ->
scene update on a running viser server, no browser). For every request the latency is
the time from ``drag_to`` until a scene update covering it has been queued for the
browser tab (the solve of a later request covers an earlier, dropped one). One headless
tab is connected (:class:`naseview.app.headless_tab.HeadlessTab`): each tab has its own
scene, so the updates are queued on that tab's connection; ``--tabs N`` connects more
(every tab's scene is updated by the same solve). Bytes are the serialised size (msgpack
+ raw arrays, before zstd) of the messages queued per update for the first tab.

With the texture on (default; ``--no-texture`` for the plain skin), the face is textured
from four photos of the ICT face rendered here (front, both profiles, base; a skin
pattern), baked once before the tab connects: every update then carries the nose part's
GLB with its cropped texture JPEG (:mod:`naseview.app.face_glb`).

Usage: ``python benchmarks/bench_app.py [--steps 60] [--landmarks prn,al_l,r]
[--no-texture]``.
Needs the ICT model (``NASEVIEW_ICT_MODEL`` or an installed one).

Targets (issue 6): median <= 50 ms, p95 <= 100 ms, >= 10 updates per second.
"""

from __future__ import annotations

import argparse
import threading
import time
from collections import defaultdict

import msgspec
import numpy as np
from _shared import use_shared_ict

from naseview.app.face_look import make_look, set_face_look
from naseview.app.guard import guarded_viser_server
from naseview.app.headless_tab import HeadlessTab
from naseview.app.naseview_app import NaseviewApp
from naseview.camera import standard_camera
from naseview.editing.baseline import Baseline, baseline_from_face_model
from naseview.facemodel import load_face_model
from naseview.render import render_mesh


def message_bytes(message: object) -> int:
    """Serialised size of one viser message (msgpack + binary buffers)."""
    buffers: list[memoryview] = []
    d = message.as_serializable_dict(buffers)  # type: ignore[attr-defined]
    return len(msgspec.msgpack.encode(d)) + sum(b.nbytes for b in buffers)


def skin_photos(baseline: Baseline, size: int = 1024) -> tuple[dict, dict]:
    """Four photos (BGR, ``size`` px) of the face with a skin pattern, and their cameras."""
    V, F = baseline.V, baseline.F
    rgb = np.column_stack([205 + 25 * np.sin(V[:, 0] / 7.0), 165 + 20 * np.cos(V[:, 1] / 9.0),
                           140 + 15 * np.sin((V[:, 0] + V[:, 2]) / 5.0)]) / 255.0
    cams, photos = {}, {}
    for view, std in (("front", "front"), ("left", "left"), ("right", "right"),
                      ("bottom", "base")):
        cam = standard_camera(V, std, size)
        cams[view] = cam
        photos[view] = (render_mesh(V, F, cam, vertex_colors=rgb[:, ::-1],
                                    background=(0, 255, 0)).image)
    return cams, photos


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=60, help="drag events per drag")
    ap.add_argument("--landmarks", default="prn,al_l,r", help="landmarks to drag")
    ap.add_argument("--interval-ms", type=float, default=50.0)
    ap.add_argument("--amplitude-mm", type=float, default=4.0)
    ap.add_argument("--tabs", type=int, default=1, help="browser tabs connected")
    ap.add_argument("--no-texture", action="store_true", help="the untextured face")
    args = ap.parse_args()
    use_shared_ict()
    model = load_face_model("ict")
    baseline = baseline_from_face_model(model)
    server = guarded_viser_server("127.0.0.1", 0, verbose=False)
    app = NaseviewApp(server)
    t0 = time.perf_counter()
    app.open_baseline(baseline, case_id="ict-mean")
    assert app.wait_ready(120), "app not ready"
    t_ready = time.perf_counter() - t0
    ctl = app.controller
    bake = ""
    if not args.no_texture:
        cams, photos = skin_photos(baseline)
        look = make_look(baseline, app.moving, cams, photos)
        assert look.texture is not None
        set_face_look(app, look)
        bake = f"texture baked in {look.bake_s:.1f} s; "
    tabs = [HeadlessTab(server) for _ in range(max(1, args.tabs))]
    end = time.monotonic() + 60
    while not all((s := app.screen_of(t.client)) is not None and s.shown.is_set()
                  for t in tabs):
        assert time.monotonic() < end, "the tabs' screens were not built"
        time.sleep(0.02)
    screen = app.screen_of(tabs[0].client)
    assert ctl is not None and screen is not None and screen.scene is not None
    scene = screen.scene

    # bytes of every message queued for the first tab, attributed to the update
    lock = threading.Lock()
    by_node: dict[str, int] = defaultdict(int)
    total = [0]
    ws = tabs[0].client._websock_connection
    orig = ws.queue_message

    def counting(m: object) -> None:
        n = message_bytes(m)
        with lock:
            total[0] += n
            by_node[str(getattr(m, "name", type(m).__name__))] += n
        orig(m)

    ws.queue_message = counting  # type: ignore[method-assign]
    done: dict[int, float] = {}
    # after every tab's scene listener: the update has been queued for every tab
    ctl.on_simulation.append(lambda s: done.setdefault(s.revision, time.perf_counter()))

    rows = []
    lat_all: list[float] = []
    final_all: list[float] = []
    solve_all: list[float] = []
    nbytes: list[float] = []
    rates: list[float] = []
    for lid in args.landmarks.split(","):
        p0 = ctl.landmarks[lid]
        direction = np.array([0.3, 1.0, 0.5]) / np.linalg.norm([0.3, 1.0, 0.5])
        ctl.begin_drag(lid)
        sent: list[tuple[int, float]] = []
        n_pub0 = len(done)
        with lock:
            total[0] = 0
        ctl.solve_seconds.clear()
        t_start = time.perf_counter()
        for i in range(1, args.steps + 1):
            target = p0 + direction * args.amplitude_mm * np.sin(np.pi * i / args.steps)
            ctl.drag_to(lid, target)
            sent.append((ctl._rev, time.perf_counter()))  # noqa: SLF001 - benchmark probe
            time.sleep(max(0.0, t_start + i * args.interval_ms / 1000 - time.perf_counter()))
        ctl.wait_idle(30)
        t_drag = time.perf_counter() - t_start
        with lock:
            drag_bytes = total[0]
        n_pub = len(done) - n_pub0
        t_end = time.perf_counter()
        ctl.end_drag()
        ctl.wait_idle(30)
        final = max(done.values()) - t_end
        revs = np.array(sorted(done))
        times = np.array([done[r] for r in revs])
        lat = []
        for rev, t in sent:
            j = np.searchsorted(revs, rev)
            if j < len(revs):
                lat.append(times[j:].min() - t)
        lat_ms = np.array(lat) * 1e3
        lat_all += list(lat_ms)
        final_all.append(final * 1e3)
        solve_all += [s * 1e3 for s in ctl.solve_seconds]
        nbytes.append(drag_bytes / max(1, n_pub))
        rates.append(n_pub / t_drag)
        rows.append((lid, np.median(lat_ms), np.percentile(lat_ms, 95), n_pub / t_drag,
                     drag_bytes / max(1, n_pub) / 1024, final * 1e3))
        ctl.undo()
        ctl.wait_idle(30)

    n_nose = len(scene.nose_ids)
    print(f"ICT face: {len(baseline.V)} vertices, {len(baseline.F)} triangles; nose mesh sent "
          f"live: {n_nose} vertices ({n_nose * 12 / 1024:.1f} KiB as float32); {bake}app ready in "
          f"{t_ready:.1f} s; {len(tabs)} tab(s); drag events every {args.interval_ms:g} ms, "
          f"{args.steps} per drag")
    print()
    print(f"{'landmark':9s} {'median ms':>10s} {'p95 ms':>8s} {'updates/s':>10s} "
          f"{'KiB/update':>11s} {'final solve ms':>15s}")
    for lid, med, p95, rate, kib, fin in rows:
        print(f"{lid:9s} {med:10.1f} {p95:8.1f} {rate:10.1f} {kib:11.1f} {fin:15.1f}")
    lat = np.array(lat_all)
    print()
    print(f"{'metric':38s} {'value':>10s} {'target':>10s}")
    print(f"{'drag-update latency, median (ms)':38s} {np.median(lat):10.1f} {'<= 50':>10s}")
    print(f"{'drag-update latency, p95 (ms)':38s} {np.percentile(lat, 95):10.1f} {'<= 100':>10s}")
    print(f"{'interactive solve alone, median (ms)':38s} {np.median(solve_all):10.1f} {'':>10s}")
    print(f"{'visible updates per second, min':38s} {min(rates):10.1f} {'>= 10':>10s}")
    print(f"{'bytes per update, mean (KiB)':38s} {np.mean(nbytes) / 1024:10.1f} {'':>10s}")
    print(f"{'full solve at drag end, median (ms)':38s} {np.median(final_all):10.1f} {'':>10s}")
    print()
    print("bytes by scene node over all drags (KiB):",
          ", ".join(f"{k} {v / 1024:.0f}" for k, v in
                    sorted(by_node.items(), key=lambda kv: -kv[1])[:6]))
    for t in tabs:
        t.close()
    app.close()
    server.stop()


if __name__ == "__main__":
    main()
