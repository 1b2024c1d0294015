"""Setting a viser GUI input's value, type-checked.

viser 1.1 defines the ``value`` setter of its input handles apart from the getter, so mypy
sees ``handle.value = x`` as assigning a read-only property; :func:`set_value` is the one
place that says so (the setter exists and syncs the value to every browser).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, TypeVar

import viser

if TYPE_CHECKING:
    from viser._gui_handles import GuiProgressBarHandle  # not exported by viser 1.1

T = TypeVar("T")


def set_value(handle: viser.GuiInputHandle[T] | GuiProgressBarHandle, value: T) -> None:
    """``handle.value = value`` (sent to every browser that shows the input)."""
    handle.value = value  # type: ignore[misc]  # viser 1.1's setter, invisible to mypy
