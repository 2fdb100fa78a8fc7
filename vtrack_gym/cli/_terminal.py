"""Everything the ``vtrack`` command writes to a terminal goes through here: text from data is escaped.

Store strings, file names and error messages may hold characters a terminal acts on instead of showing: C0 and
C1 control characters (ANSI escape sequences start with ESC), DEL, bidirectional controls that reorder what is
shown, zero-width characters that hide text, and line/paragraph separators. ``terminal_safe`` shows each as a
Python-style escape (``\\x1b``, ``\\u202e``); newlines and tabs are kept (they lay out tables and messages).
"""

from __future__ import annotations

import logging
import re
import sys
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from typing import Any, TextIO

_UNSAFE = re.compile("[\x00-\x08\x0b-\x1f\x7f-\x9f\u061c\u200b-\u200f\u202a-\u202e\u2028\u2029\u2060-\u2069"
                     "\ufeff]")


def terminal_safe(text: object) -> str:
    """``str(text)`` with every terminal-unsafe character (see the module docstring) as a visible escape."""
    return _UNSAFE.sub(lambda m: m.group().encode("unicode_escape").decode("ascii"), str(text))


_RESULTS: ContextVar[TextIO | None] = ContextVar("vtrack_results_stream", default=None)
"""Where ``out`` writes while ``results_only_on_stdout`` is active (the real stdout)."""


def out(text: object = "", flush: bool = False) -> None:
    """Print ``text`` (escaped) to stdout: what the command produces (tables, JSON, result lines)."""
    print(terminal_safe(text), file=_RESULTS.get() or sys.stdout, flush=flush)


@contextmanager
def results_only_on_stdout() -> Iterator[None]:
    """Within the block only ``out`` writes to stdout: anything else printed there (Ray's worker logs, a library's
    progress prints) goes to stderr, so ``vtrack ... --format json > file`` holds the result alone."""
    stdout = sys.stdout
    token = _RESULTS.set(stdout)
    sys.stdout = sys.stderr
    try:
        yield
    finally:
        sys.stdout = stdout
        _RESULTS.reset(token)
        stdout.flush()


def err(text: object = "") -> None:
    """Print ``text`` (escaped) to stderr: notes, progress and errors."""
    print(terminal_safe(text), file=sys.stderr)


def write_safe(text: str, file: TextIO) -> None:
    """Write ``text`` (escaped) to ``file`` (argparse's usage, help and errors)."""
    file.write(terminal_safe(text))


class SafeFormatter(logging.Formatter):
    """A log formatter whose lines are escaped like every other line the command writes."""

    def format(self, record: logging.LogRecord) -> str:
        return terminal_safe(super().format(record))


@contextmanager
def safe_warnings() -> Iterator[None]:
    """Within the block, warnings are shown with their message and file name escaped (the previous way of
    showing them is kept: a test recording warnings still records them); restored afterwards."""
    with warnings.catch_warnings():
        previous = warnings.showwarning

        def show(message: Any, category: type[Warning], filename: str, lineno: int, file: Any = None,
                 line: str | None = None) -> None:
            previous(terminal_safe(message), category, terminal_safe(filename), lineno, file, line)

        warnings.showwarning = show
        yield
