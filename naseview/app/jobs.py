"""The served app's background jobs: one runner, and what the status line says of them.

:class:`JobRunner` runs opening, reconstruction and recompute jobs on a background thread,
one after the other in effect: each gets a sequence number, and a later job supersedes an
earlier one (which sees :meth:`JobRunner.is_current` turn False and drops its result).
Progress and status go to every tab, an error to the tab that asked.
:func:`reconstruction_summary` is the status a surgeon reads after a reconstruction
(the pipeline's stages 1-3, paper §3.2-3.4).
"""

from __future__ import annotations

import logging
import re
import threading
import traceback
from collections.abc import Callable

from naseview.app.landmark_names import display_name
from naseview.errors import NaseviewError
from naseview.facemodel import store
from naseview.facemodel.ict import ICT_CREDIT
from naseview.landmarks import LANDMARKS
from naseview.pipeline import PipelineResult
from naseview.stage1_landmarks import SfmResult

log = logging.getLogger(__name__)

STAGE_LABELS: dict[int, str] = {1: "landmarks (bundle adjustment)", 2: "curves",
                                3: "mesh (ARAP)"}
"""What the progress line calls each pipeline stage while it runs."""


class JobRunner:
    """Background jobs, the latest one in effect.

    Args:
        set_progress: the progress bar of every tab (``None`` hides it).
        set_status: the status line of every tab.
    """

    def __init__(self, set_progress: Callable[[float | None], None],
                 set_status: Callable[[str], None]) -> None:
        self._set_progress = set_progress
        self._set_status = set_status
        self._lock = threading.Lock()
        self._seq = 0
        self.ready = threading.Event()
        """Set while no job runs (cleared when one starts, set when the latest ends)."""

    def is_current(self, seq: int) -> bool:
        """Whether job ``seq`` is still the latest (not superseded)."""
        return seq == self._seq

    def start(self, fn: Callable[[int], None], label: str,
              show_error: Callable[[str], None]) -> None:
        """Run ``fn(seq)`` on a background thread; a later job supersedes it. Progress
        and status go to every tab; a failure of the latest job is logged, shown with
        ``show_error`` (one line) and in the status."""
        with self._lock:
            self._seq += 1
            seq = self._seq
            self.ready.clear()

        def run() -> None:
            self._set_progress(0.02)
            self._set_status(f"{label}…")
            try:
                fn(seq)
            except Exception as e:
                log.error("naseview: %s failed:\n%s", label, traceback.format_exc())
                if self.is_current(seq):
                    msg = str(e) if isinstance(e, NaseviewError) else f"{type(e).__name__}: {e}"
                    show_error(f"{label} failed: {msg}")
                    self._set_status(f"{label} failed.")
            finally:
                if self.is_current(seq):
                    self._set_progress(None)
                    self.ready.set()

        threading.Thread(target=run, name=f"naseview-{label}", daemon=True).start()


def model_credit(model: str | None, result: PipelineResult) -> str:
    """Attribution line of the face model used by stage 3."""
    refined = result.refined
    if refined is not None and refined.credit:
        return str(refined.credit)
    name = (refined.model_name if refined is not None else None) or model
    if name == "ict" or (name is None and store.find_ict_npz() is not None):
        return ICT_CREDIT
    return ""


def suspect_messages(sfm: SfmResult | None) -> list[str]:
    """One line per click stage 1 flagged as suspect."""
    return [s.message() for s in sfm.suspect_clicks] if sfm is not None else []


def reconstruction_summary(case_id: str, seconds: float, rmse_px: float | None,
                           warnings: list[str], most: int = 6) -> str:
    """The status a surgeon reads after a reconstruction: a plain first line, then the
    pipeline's warnings as "notes to check" with landmarks named in words.

    >>> print(reconstruction_summary("P001", 1.23, 0.85,
    ...       ["landmark 'int_l' is clicked in photo 'left' only; click it in a second photo"]))
    **P001** is ready (reconstructed in 1.2 s; the clicks fit the photos to 0.85 px).
    <BLANKLINE>
    Notes to check (1):
    - landmark Alar groove, top (L) is clicked in photo 'left' only; click it in a second photo
    """
    fit = f"; the clicks fit the photos to {rmse_px:.2f} px" if rmse_px is not None else ""
    lines = [f"**{case_id}** is ready (reconstructed in {seconds:.1f} s{fit})."]
    if warnings:
        lines += ["", f"Notes to check ({len(warnings)}):"]
        lines += [f"- {_named(w.removeprefix('stage 3: '))}" for w in warnings[:most]]
    return "\n".join(lines)


def _named(text: str) -> str:
    """``text`` with each quoted landmark id (``'int_l'``) replaced by its readable name."""
    return re.sub(r"'([a-z]+(?:_[lr])?)'",
                  lambda m: display_name(m.group(1)) if m.group(1) in LANDMARKS
                  else m.group(0), text)


__all__ = ["JobRunner", "STAGE_LABELS", "model_credit", "reconstruction_summary",
           "suspect_messages"]
