"""Is there enough compressed image data for the size a PNG / JPEG header declares?

:func:`naseview.fileio.image_header` refuses a file smaller than the pixels it declares
need. A JPEG can still lie with a file large enough: a small real picture whose frame
header is patched to 8000 x 8000 px, padded with a comment or an application segment (or
bytes after its end marker). libjpeg then "decodes" it as 192 MB of grey after printing
"Corrupt JPEG data: premature end of data segment". What counts is the entropy-coded
data of its scans: Huffman coding spends at least one bit on every 8x8 block of the
fully sampled component (the DC difference has a code of at least one bit, in a
sequential or a progressive first DC scan), so a JPEG declaring ``W x H`` px needs at
least ``ceil(W/8) * ceil(H/8) / 8`` bytes of scan data; :func:`too_little_data` refuses
one below half that. A PNG's deflate stream compresses at most 1032:1, so its ``IDAT``
chunks must hold at least its raw rows / 1032 bytes (half that is the floor here).

Arithmetic-coded JPEGs (which no camera writes) can spend less than a bit a block; only
the file-size floor of :func:`~naseview.fileio.image_header` applies to them.

>>> too_little_data(b"\\xff\\xd8\\xff\\xd9", "jpeg", 8000, 8000) is None  # no scan: not ours
True
"""

from __future__ import annotations

import re
import struct

_MARKER = re.compile(rb"\xff[^\x00\xd0-\xd7\xff]")
"""A marker that ends entropy-coded data (stuffed 0xFF00 bytes and restart markers are
part of it; 0xFF fill bytes come before a marker)."""

_ARITHMETIC_SOF = {0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF}
_SOF = {0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7} | _ARITHMETIC_SOF

MARGIN = 2
"""The floors are divided by this: a real file holds at least twice what is required."""


def jpeg_scan_bytes(data: bytes) -> tuple[int, bool] | None:
    """(bytes of entropy-coded data in all scans, arithmetic-coded) of a JPEG, from its
    markers; None when the marker structure cannot be followed or there is no scan."""
    i = 2
    scans = 0
    total = 0
    arithmetic = False
    n = len(data)
    while i + 2 <= n:
        if data[i] != 0xFF:
            return None
        marker = data[i + 1]
        if marker == 0xFF:
            i += 1
            continue
        if marker == 0xD9:
            break
        if marker == 0x01 or 0xD0 <= marker <= 0xD8:
            i += 2
            continue
        if i + 4 > n:
            return None
        length = (data[i + 2] << 8) | data[i + 3]
        if length < 2:
            return None
        arithmetic |= marker in _ARITHMETIC_SOF
        i += 2 + length
        if marker == 0xDA:  # entropy-coded data up to the next real marker
            scans += 1
            m = _MARKER.search(data, i)
            end = n if m is None else m.start()
            total += max(0, end - i)
            i = end
    return (total, arithmetic) if scans else None


def _png_idat_bytes(data: bytes) -> int:
    """Bytes in the ``IDAT`` chunks of a PNG (the compressed pixels)."""
    i = 8
    total = 0
    while i + 8 <= len(data):
        length = struct.unpack(">I", data[i:i + 4])[0]
        kind = data[i + 4:i + 8]
        if kind == b"IDAT":
            total += min(length, max(0, len(data) - i - 8))
        elif kind == b"IEND":
            break
        i += 12 + length
    return total


def too_little_data(data: bytes, kind: str, width: int, height: int,
                    raw_bytes: int = 0) -> str | None:
    """Why the compressed pixels of a whole PNG / JPEG file cannot be the ``width`` x
    ``height`` px its header declares (a phrase for an error message), or None when they
    can. ``raw_bytes``: a PNG's uncompressed rows (filter bytes included)."""
    if kind == "jpeg":
        scan = jpeg_scan_bytes(data)
        if scan is None or scan[1]:
            return None
        have = scan[0]
        need = -(-width // 8) * -(-height // 8) // 8
    elif kind == "png":
        have = _png_idat_bytes(data)
        need = raw_bytes // 1032
    else:
        return None
    if have * MARGIN >= need:
        return None
    return (f"its header declares {width}x{height} px but its image data holds only "
            f"{have:,} bytes, far fewer than such an image needs")


__all__ = ["MARGIN", "jpeg_scan_bytes", "too_little_data"]
