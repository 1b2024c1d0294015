"""The report as a PDF: the HTML page printed to A4 by headless Chromium.

The page's own ``@page { size: A4 }`` style fixes the paper; Chromium prints it without
its header and footer (no file path or date in the margins) and fetches nothing (the
page embeds its images). The PDF is written atomically: Chromium prints to a temporary
file beside the target, which is renamed over it only when it is a complete PDF, so a
failed print leaves no half file and an earlier PDF unchanged. The PDF's creation and
modification dates are blanked (same length, so the cross-reference table stays valid):
the report names its date on the page, and the de-identified version names none.

Example
-------
    write_report_pdf("out/report.html", "out/report.pdf")
    # -> PosixPath('out/report.pdf')
"""

from __future__ import annotations

import os
import re
import shutil
import signal
import subprocess
import tempfile
import uuid
from pathlib import Path

from naseview.errors import NaseviewError

CHROMIUM_NAMES = ("chromium", "chromium-browser")
"""Executable names searched on ``PATH`` for printing."""

PRINT_TIMEOUT_S = 120.0
"""Longest a print may take before it counts as failed."""

_PDF_DATE = re.compile(rb"/(CreationDate|ModDate)\s*\((D:[^)]*)\)")


def find_chromium() -> str:
    """Path of the Chromium executable (:data:`CHROMIUM_NAMES` on ``PATH``).

    Raises:
        NaseviewError: none installed (names the fix).
    """
    for name in CHROMIUM_NAMES:
        path = shutil.which(name)
        if path:
            return path
    raise NaseviewError("printing the report to PDF needs Chromium, which is not "
                        "installed; install it (apt-get install chromium) or use the HTML")


def _blank_dates(pdf: bytes) -> bytes:
    """``pdf`` with its ``/CreationDate`` and ``/ModDate`` strings replaced by spaces of
    the same length (byte offsets, hence the xref table, unchanged)."""
    return _PDF_DATE.sub(lambda m: b"/" + m.group(1) + b"(" + b" " * len(m.group(2)) + b")",
                         pdf)


def write_report_pdf(html_path: str | os.PathLike[str], pdf_path: str | os.PathLike[str],
                     timeout_s: float = PRINT_TIMEOUT_S) -> Path:
    """Print the report page ``html_path`` to ``pdf_path`` (A4, by headless Chromium).

    Args:
        html_path: a report written by :func:`naseview.report.write_report`.
        pdf_path: the PDF to write (``.pdf``), replaced atomically.
        timeout_s: longest the print may take.
    Returns:
        ``pdf_path``.
    Raises:
        NaseviewError: no HTML file, a name not ending in ``.pdf``, Chromium missing, or
            the print failed / timed out (the target is then unchanged).
    """
    html_file = Path(html_path).resolve()
    pdf = Path(pdf_path)
    if not html_file.is_file():
        raise NaseviewError(f"{html_path}: no such report page; write the HTML report "
                            "first (naseview report PATH)")
    if pdf.suffix.lower() != ".pdf":
        raise NaseviewError(f"{pdf}: the printed report is a PDF file; give a name ending "
                            "in .pdf")
    chromium = find_chromium()
    tmp = pdf.parent / f".{pdf.stem}.{os.getpid()}-{uuid.uuid4().hex[:8]}.pdf.tmp"
    try:
        with tempfile.TemporaryDirectory(prefix="naseview-print-") as profile:
            cmd = [chromium, "--headless", "--no-sandbox", "--disable-gpu",
                   "--disable-background-networking", "--no-first-run",
                   "--disable-extensions", f"--user-data-dir={profile}",
                   "--no-pdf-header-footer", f"--print-to-pdf={tmp}",
                   html_file.as_uri()]
            proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL,
                                    stderr=subprocess.PIPE, start_new_session=True)
            try:
                _, stderr = proc.communicate(timeout=timeout_s)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)   # Chromium and its helpers only
                proc.communicate()
                raise NaseviewError(f"{pdf}: Chromium did not finish printing within "
                                    f"{timeout_s:g} s; try again or print the HTML from "
                                    "a browser") from None
        data = tmp.read_bytes() if tmp.is_file() else b""
        if proc.returncode != 0 or not data.startswith(b"%PDF") or b"%%EOF" not in data[-64:]:
            err = stderr.decode("utf-8", "replace").strip().splitlines()
            raise NaseviewError(f"{pdf}: Chromium could not print {html_file.name} (exit "
                                f"{proc.returncode}{': ' + err[-1] if err else ''}); print "
                                "the HTML from a browser instead")
        tmp.unlink()
        with open(tmp, "xb") as fh:           # a new file: the usual permissions
            fh.write(_blank_dates(data))
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, pdf)
    except OSError as e:
        raise NaseviewError(f"{pdf}: could not write the PDF ({e.strerror}); free some "
                            "disk space or choose another folder (an earlier PDF is "
                            "unchanged)") from None
    finally:
        tmp.unlink(missing_ok=True)
    return pdf
