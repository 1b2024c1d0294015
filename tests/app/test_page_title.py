"""The browser tab says naseview, not "Viser" (issue 14, item 4), gzip-encoded or not."""

from __future__ import annotations

import gzip
import http.client

from naseview.app.guard import guarded_viser_server


def _page(port: int, accept_gzip: bool) -> tuple[bytes, str | None, str | None]:
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=10)
    try:
        headers = {"Accept-Encoding": "gzip"} if accept_gzip else {}
        conn.request("GET", "/", headers=headers)
        r = conn.getresponse()
        return r.read(), r.getheader("Content-Encoding"), r.getheader("Content-Length")
    finally:
        conn.close()


def test_served_page_is_titled_naseview() -> None:
    server = guarded_viser_server("127.0.0.1", 0, verbose=False)
    try:
        port = server.get_port()
        plain, enc, length = _page(port, accept_gzip=False)
        assert enc != "gzip" and length == str(len(plain))
        zipped, enc, length = _page(port, accept_gzip=True)
        assert enc == "gzip" and length == str(len(zipped))
        for body in (plain, gzip.decompress(zipped)):
            assert b"<title>naseview</title>" in body
            assert b"<title>Viser</title>" not in body
            assert b"</html>" in body.lower()  # the whole page still arrives
    finally:
        server.stop()
