"""The one error type shown to the user, as one line."""

from __future__ import annotations


class NaseviewError(Exception):
    """A user-facing error: one line naming the file, the key and the fix.

    The CLI prints ``naseview: error: <message>`` and exits with status 2; the app shows the
    message in the page. Raise it only with a message a surgeon can act on.
    """
