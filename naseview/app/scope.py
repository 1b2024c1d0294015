"""Who a piece of the page reaches: one browser tab, or every tab of the server.

viser has two scopes with the same ``gui`` / ``scene`` / ``atomic()`` API: the server's
(every browser sees it, and it outlives a reload) and a client's (one tab, gone with its
connection). The app builds each tab's panels, scene and pages in that tab's client scope
(:class:`naseview.app.screen.Screen`); a page built on the server scope (a test, a
stand-alone page) reaches every tab. :func:`clients_of` and :func:`notify` are the one
place that tells the two apart.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Literal

import viser

from naseview.errors import NaseviewError

log = logging.getLogger(__name__)

Scope = viser.ViserServer | viser.ClientHandle
"""A viser scope: the server (every tab) or one client (one tab)."""

NoticeColor = Literal["blue", "red", "green"]
"""Colours of the app's notifications."""


def clients_of(scope: Scope) -> list[viser.ClientHandle]:
    """The connected tabs ``scope`` reaches (a client: itself)."""
    if isinstance(scope, viser.ClientHandle):
        return [scope]
    return list(scope.get_clients().values())


def run_action(fn: Callable[[], object], show: Callable[[str], None],
               what: str = "action") -> None:
    """Run a page action (a button, a queued step): a :class:`NaseviewError` is shown with
    ``show`` as its one line; anything else is logged with its traceback and shown as one
    line too, so a failed action never stops the page or the server."""
    try:
        fn()
    except NaseviewError as e:
        show(str(e))
    except Exception as e:
        log.exception("naseview: %s failed", what)
        show(f"{type(e).__name__}: {e}")


def notify(scope: Scope, title: str, body: str, color: NoticeColor = "blue",
           seconds: float = 6.0, client: viser.ClientHandle | None = None) -> None:
    """A notification in ``client`` (default: every tab of ``scope``); a tab that has
    gone away meanwhile is skipped."""
    for c in [client] if client is not None else clients_of(scope):
        try:
            c.add_notification(title, body, color=color, auto_close_seconds=seconds)
        except Exception:  # the tab closed meanwhile
            log.debug("naseview: notification to a closed tab dropped", exc_info=True)


__all__ = ["NoticeColor", "Scope", "clients_of", "notify"]
