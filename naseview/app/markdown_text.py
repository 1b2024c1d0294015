"""Text shown literally in a viser markdown element (file names, ids, simulation names).

viser renders a markdown element's raw HTML unsanitized, so anything that comes from a
file, a folder name or the surgeon's typing is escaped here before it is put in one.
"""

from __future__ import annotations

import html
import re

_MARKDOWN_SPECIAL = re.compile(r"([\\`*_{}\[\]()#+!|~>-])")


def markdown_text(text: str) -> str:
    """``text`` shown literally in a viser markdown element, which renders raw HTML
    unsanitized: a file name such as ``<img src=x onerror=...>.jpg`` must stay text.

    >>> print(markdown_text("<b>front_1</b>.jpg"))
    &lt;b&gt;front\\_1&lt;/b&gt;.jpg
    """
    return _MARKDOWN_SPECIAL.sub(r"\\\1", html.escape(text, quote=False))


__all__ = ["markdown_text"]
