"""Progress bars of the package's long work: tqdm on a terminal, one plain line per update elsewhere.

On a terminal a bar redraws itself in place. Redirected to a file or a CI log, tqdm's carriage-return redraws
pile up on one line and cut through log lines; there the bar writes a whole line at most every
``LOG_INTERVAL_S`` seconds instead, its last state when it closes, and only when the count moved.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable
from typing import Any, TextIO

LOG_INTERVAL_S = 30.0
"""Shortest time between two progress lines when stderr is not a terminal [s]."""


class LineStream:
    """A text stream for tqdm that turns its redraws into lines on ``stream``: at most one per ``interval_s``
    seconds (the latest redraw wins), the last one when the bar closes, and only when the count moved.

    ``clock``: a monotonic time source [s] (a test passes its own)."""

    def __init__(self, stream: TextIO, interval_s: float = LOG_INTERVAL_S,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self._stream = stream
        self._interval_s = interval_s
        self._clock = clock
        self._last = ""
        self._last_at = -math.inf
        self._pending = ""

    @property
    def encoding(self) -> str | None:
        return getattr(self._stream, "encoding", None)

    def write(self, text: str) -> int:
        line = text.replace("\r", " ").strip()
        if line:
            self._pending = line
            if self._clock() - self._last_at >= self._interval_s:
                self._emit()
        elif "\n" in text:  # the bar closed (tqdm ends a kept bar with a newline): its last state
            self._emit()
        return len(text)

    def _emit(self) -> None:
        if self._pending and _counts(self._pending) != _counts(self._last):
            self._stream.write(self._pending + "\n")
            self._last, self._last_at = self._pending, self._clock()
        self._pending = ""

    def flush(self) -> None:
        self._stream.flush()


def _counts(line: str) -> str:
    """A bar's line without its timing bracket ('run:  50%| | 2/4 [00:31<00:31, 1.2s/it]' -> 'run:  50%| | 2/4'):
    two lines that differ only there say nothing new."""
    return line.rpartition(" [")[0] or line


def _redraws_in_place(stream: Any) -> bool:
    """True for a terminal and for a Jupyter kernel's stream (both render carriage returns)."""
    if type(stream).__module__.startswith("ipykernel"):
        return True
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):  # no isatty, or a closed stream
        return False


def progress_bar(iterable: Any = None, **kwargs: Any) -> Any:
    """A ``tqdm`` bar on stderr with ``kwargs`` (``total``, ``desc``, ``unit``, ``disable``, ...); when stderr is
    neither a terminal nor a notebook's, it writes plain lines through ``LineStream``."""
    from tqdm.auto import tqdm

    if not _redraws_in_place(sys.stderr):
        kwargs["file"] = LineStream(sys.stderr)
    return tqdm(iterable, **kwargs)


class EpisodeCounts:
    """The episodes of a run counted on a progress bar: each one, finished (``done``), lost (its worker process
    died) or failed (it raised), advances the bar by one, and once one was lost or failed the bar says how many of
    each beside its count: ``14/14 [..., 12 done, 2 lost]``. ``bar``: a tqdm bar, or None (counts only)."""

    OUTCOMES = ("done", "lost", "failed")

    def __init__(self, bar: Any = None) -> None:
        self.bar = bar
        self.counts = dict.fromkeys(self.OUTCOMES, 0)

    def add(self, outcome: str) -> None:
        """One more episode of ``outcome`` (one of ``OUTCOMES``)."""
        if outcome not in self.counts:
            raise ValueError(f"outcome must be one of {', '.join(self.OUTCOMES)} (got {outcome!r})")
        self.counts[outcome] += 1
        if self.bar is None:
            return
        if self.counts["lost"] or self.counts["failed"]:
            self.bar.set_postfix_str(self.text(), refresh=False)
        self.bar.update(1)

    def text(self) -> str:
        """``12 done, 2 lost`` (the outcomes that occurred, ``done`` always)."""
        return ", ".join(f"{n} {name}" for name, n in self.counts.items() if n or name == "done")
