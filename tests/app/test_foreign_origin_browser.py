"""A real foreign web page cannot read the patient (issue 12, finding 1), in Chromium.

``naseview serve`` of the bundled demo case (four photos, mesh, landmarks) runs on one
port; a tiny page served by Python's ``http.server`` on another localhost port (another
origin, as any other local web app or a site the surgeon visits would be) tries what a
hostile page would: open viser's websocket (with viser's own subprotocol) on
``127.0.0.1`` and ``localhost``, and show the app in an ``<iframe>``. Playwright drives
it with the system's ``/usr/bin/chromium``: no socket opens, no byte arrives, no client
reaches the server. The naseview page itself still connects and receives the case, and
every request it makes goes to the server's own origin (no CDN, no font or map fetch).

Without Chromium or Playwright the test skips, except in CI (``CI=true``), where it fails.
"""

from __future__ import annotations

import http.server
import json
import threading
import time
from collections.abc import Iterator
from typing import Any

import pytest
import viser
from helpers import CHROMIUM, CHROMIUM_FLAGS, browser_or_skip, wait_for

pytestmark = pytest.mark.browser


FOREIGN_PAGE = """<!doctype html>
<html><body>
<p>Another web page</p>
<iframe id="frame" src="http://127.0.0.1:{port}/" width="400" height="300"></iframe>
<script>
const report = {{sockets: {{}}, done: 0}};
window.report = report;
for (const host of ["127.0.0.1", "localhost"]) {{
  const r = {{opened: false, bytes: 0, messages: 0, closed: false, code: null}};
  report.sockets[host] = r;
  const ws = new WebSocket("ws://" + host + ":{port}/", [{subprotocol}]);
  ws.binaryType = "arraybuffer";
  ws.onopen = () => {{ r.opened = true; }};
  ws.onmessage = (e) => {{ r.messages += 1; r.bytes += e.data.byteLength || e.data.length; }};
  ws.onclose = (e) => {{ r.closed = true; r.code = e.code; report.done += 1; }};
}}
</script>
</body></html>
"""


def browser_tools() -> Any:
    """Playwright's sync API, with Chromium present: skip without them, fail in CI."""
    browser_or_skip()
    from playwright import sync_api  # after the check: a missing package fails in CI

    return sync_api


@pytest.fixture()
def foreign_site(served) -> Iterator[str]:
    """``http://localhost:<other port>/``: the hostile page, from another origin."""
    server, _ = served
    body = FOREIGN_PAGE.format(port=server.get_port(),
                               subprotocol=json.dumps(f"viser-v{viser.__version__}"))

    class Handler(http.server.BaseHTTPRequestHandler):
        def do_GET(self) -> None:  # noqa: N802 (http.server's name)
            data = body.encode("utf-8")
            self.send_response(200)
            self.send_header("Content-Type", "text/html; charset=utf-8")
            self.send_header("Content-Length", str(len(data)))
            self.end_headers()
            self.wfile.write(data)

        def log_message(self, *_args: object) -> None:
            pass

    site = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    thread = threading.Thread(target=site.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://localhost:{site.server_address[1]}/"
    finally:
        site.shutdown()
        site.server_close()


def test_foreign_page_gets_nothing_and_own_page_connects(served, foreign_site: str) -> None:
    sync_api = browser_tools()
    server, _ = served
    port = server.get_port()
    own = f"http://127.0.0.1:{port}"
    connected: list[int] = []
    server.on_client_connect(lambda client: connected.append(client.client_id))
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=CHROMIUM_FLAGS)
        try:
            # the hostile page: its sockets are refused, the app will not load in its frame
            page = browser.new_page()
            page.goto(foreign_site)
            wait_for(lambda: page.evaluate(
                "report.done == 2 || Object.values(report.sockets).some(r => r.bytes > 0)"),
                20, "the foreign sockets to be refused or served")
            time.sleep(2.0)                   # time for a framed app to connect, if it could
            report = page.evaluate("window.report")
            for host, r in report["sockets"].items():
                assert not r["opened"], f"a foreign page opened the websocket on {host}"
                assert r["bytes"] == 0 and r["messages"] == 0, (host, r)
            assert connected == [], "the app framed by a foreign page connected"
            frame = page.frame_locator("#frame")
            assert frame.locator("canvas").count() == 0
            page.close()

            # the naseview page itself: connects, receives the case, asks nobody else
            page = browser.new_page(viewport={"width": 800, "height": 500})
            requests: list[str] = []
            sockets: list[str] = []
            received = [0]
            refused: list[str] = []
            page.on("request", lambda r: requests.append(r.url))
            page.on("console", lambda m: refused.append(m.text)
                    if "Content Security Policy" in m.text else None)

            def on_socket(ws: Any) -> None:
                sockets.append(ws.url)
                ws.on("framereceived", lambda payload: received.__setitem__(
                    0, received[0] + len(payload)))

            page.on("websocket", on_socket)
            page.goto(own + "/")
            page.wait_for_selector("canvas", timeout=30_000)
            wait_for(lambda: connected, 30, "the naseview page to connect")
            # the tab's own panels and scene are built for it (per-tab scope) and sent
            app = served[1]
            wait_for(lambda: any(app.screen_of(c) is not None and app.screen_of(c).shown
                                 .is_set() for c in connected), 30, "the page's screen")
            # Playwright may attach the frame listener after the first frames arrived:
            # what it saw is a lower bound of what the page received. Its sync API runs
            # event listeners only inside its own calls, so the wait pumps them
            # (page.wait_for_timeout), where a bare sleep would see no frame at all.
            wait_for(lambda: page.wait_for_timeout(50) or received[0] > 0, 30,
                     "the case to reach the page")
            page.wait_for_timeout(3000)       # fonts, environment maps, lazy chunks
            page.close()
        finally:
            browser.close()
    assert sockets and all(u.startswith(f"ws://127.0.0.1:{port}") for u in sockets), sockets
    outside = [u for u in requests
               if not u.startswith((own + "/", "data:", "blob:"))]
    assert outside == [], f"the page made requests outside its server: {outside}"
    assert refused == [], f"the page's own security policy blocked something: {refused}"
