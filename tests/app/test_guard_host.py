"""issue 26 item 11: the ``Host`` header is parsed strictly (host[:port], nothing else)."""

from __future__ import annotations

import pytest

from naseview.app.guard import OriginPolicy


@pytest.mark.parametrize("host", [
    "evil.com@localhost:8080",      # user info: urlsplit took 'localhost' as the host
    "localhost:8080/x",             # a path after the port
    "localhost:8080?x",
    "localhost:8080#x",
    "localhost :8080",
    "localhost:+8080",
    "localhost:08080x",
    "localhost:8080:8080",
    "[::1]x:8080",
    "localhost\r\n:8080",
    "user:pw@127.0.0.1:8080",
    "127.0.0.1:99999999",
])
def test_host_header_with_anything_but_host_and_port_is_refused(host: str) -> None:
    policy = OriginPolicy.for_bind("127.0.0.1", 8080)
    assert not policy.host_ok(host)
    assert policy.refusal(host, None) == f"Host {host!r} is not this server"


@pytest.mark.parametrize("host", ["localhost:8080", "LOCALHOST:8080", "127.0.0.1:8080",
                                  "[::1]:8080", " localhost:8080 "])
def test_loopback_host_and_port_is_accepted(host: str) -> None:
    assert OriginPolicy.for_bind("127.0.0.1", 8080).host_ok(host)


def test_origin_must_repeat_the_strict_host() -> None:
    policy = OriginPolicy.for_bind("127.0.0.1", 8080)
    assert policy.refusal("localhost:8080", "http://evil.com@localhost:8080") is not None
    assert policy.refusal("localhost:8080", "http://localhost:8080") is None
