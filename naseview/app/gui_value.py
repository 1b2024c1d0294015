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


def set_options(dropdown: viser.GuiDropdownHandle[str], options: tuple[str, ...]) -> None:
    """Offer ``options`` in ``dropdown``, keeping its value when still offered (else the
    first option)."""
    if tuple(dropdown.options) == options or not options:
        return
    keep = str(dropdown.value)
    dropdown.options = options
    set_value(dropdown, keep if keep in options else options[0])
