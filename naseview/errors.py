"""Errors and warnings shown to the user as one line each."""

from __future__ import annotations


class NaseviewError(Exception):
    """A user-facing error: one line naming the file, the key and the fix.

    The CLI prints ``naseview: error: <message>`` and exits with status 2; the app shows the
    message in the page. Raise it only with a message a surgeon can act on.
    """


class NaseviewWarning(UserWarning):
    """A recoverable problem (a curve fell back to interpolation, a click looks wrong)."""
