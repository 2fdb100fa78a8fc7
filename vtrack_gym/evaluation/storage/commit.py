"""Each finished episode's row committed to the store as its episode ends: the one path every runner uses.

``RowCommit`` is handed each row as its episode ends (``vtrack_gym.evaluate`` in this process or in worker
processes, ``vtrack benchmark`` on a suite or on track files, ``vtrack eval``): it applies the caller's ``finish``
(a track's provenance), adds the row to the store in its own transaction, before the next episode starts and before
anything is printed, and keeps it. So a failure in a later episode, a kill or a closed stdout cannot lose the
episodes that finished. A store that fails (a full disk) stops the storing, not the run: the error is logged once,
``error`` keeps it, and the remaining rows are still kept for the table.

When a run stops on an exception, ``mark_stopped`` records on the exception what was stored (``stored_line``), so
whoever reports the failure can say which episodes are safe.
"""

from __future__ import annotations

import contextlib
import logging
from collections.abc import Callable
from typing import Any

from vtrack_gym.evaluation.scoring.rows import ResultRow
from vtrack_gym.evaluation.storage.store_sqlite import StoreError

log = logging.getLogger(__name__)

STORED_ATTRIBUTE = "vtrack_stored"
"""The attribute ``mark_stopped`` sets on an exception that ended a run: one sentence on what was stored."""


class RowCommit:
    """Commit each row as its episode ends (see the module docstring).

    ``store``: a writable ``ResultStore`` (None: keep the rows only). ``finish``: applied to each row before it is
    stored (an error it raises ends the run; the rows stored before stay). ``total``: the episodes of the run (for
    ``stored_line``)."""

    def __init__(self, store: Any = None, finish: Callable[[ResultRow], ResultRow] | None = None,
                 total: int = 0) -> None:
        self.store = store
        self.finish = finish
        self.total = total
        self.rows: dict[int, ResultRow] = {}
        """Every row handed in, by its episode's index (stored or not)."""
        self.stored: list[ResultRow] = []
        """The rows committed to the store, in the order they were committed."""
        self.error: StoreError | None = None
        """Why the store stopped taking rows (None: every row handed in was stored)."""

    def __call__(self, row: ResultRow, index: int | None = None) -> ResultRow:
        """``row`` finished, committed (unless the store failed before) and kept under ``index`` (default: the next
        one); returns the finished row."""
        if self.finish is not None:
            row = self.finish(row)
        if self.store is not None and self.error is None:
            try:
                self.store.add([row])
                self.stored.append(row)
            except StoreError as exc:   # a full disk: the run goes on, its table is still shown
                log.error("%s; the remaining rows are not stored", exc)
                self.error = exc
        self.rows[len(self.rows) if index is None else index] = row
        return row

    def ordered(self) -> list[ResultRow]:
        """The rows kept, in episode order."""
        return [self.rows[i] for i in sorted(self.rows)]

    def stored_line(self) -> str:
        """``2 of 4 episodes are stored in s.sqlite (seeds 0, 1)``: what a stopped run leaves in the store."""
        if self.store is None:
            return f"{len(self.rows)} of {self.total} episodes finished (no store)"
        if not self.stored:
            return f"no episode of {self.total} is stored in {self.store.path}"
        seeds = ", ".join(str(r.seed) for r in self.stored[:20]) + (", ..." if len(self.stored) > 20 else "")
        envs = sorted({r.env_id for r in self.stored})
        where = f" of {envs[0]}" if len(envs) == 1 else ""
        return (f"{len(self.stored)} of {self.total} episodes are stored in {self.store.path} "
                f"(seeds {seeds}{where})")

    def mark_stopped(self, exc: BaseException) -> None:
        """Record on ``exc`` (the exception that ended the run) what was stored (``STORED_ATTRIBUTE``)."""
        if getattr(exc, STORED_ATTRIBUTE, None) is None:
            with contextlib.suppress(AttributeError, TypeError):
                setattr(exc, STORED_ATTRIBUTE, self.stored_line())


def stored_line_of(exc: BaseException) -> str | None:
    """What the run that ``exc`` ended had stored (``RowCommit.mark_stopped``), None when it did not say."""
    line = getattr(exc, STORED_ATTRIBUTE, None)
    return line if isinstance(line, str) else None


class RowsNotStored(StoreError):
    """A run whose episodes all ran but whose store stopped taking rows (a full disk): ``rows`` holds every row of
    the run in episode order, ``stored`` those that were committed before the store failed."""

    def __init__(self, message: str, rows: list[ResultRow], stored: list[ResultRow]) -> None:
        super().__init__(message)
        self.rows = rows
        self.stored = stored

    def __reduce__(self) -> tuple[Any, ...]:
        return type(self), (str(self), self.rows, self.stored)


def raise_if_not_stored(commit: RowCommit) -> None:
    """``RowsNotStored`` (with every row) when ``commit``'s store failed during the run."""
    if commit.error is not None:
        raise RowsNotStored(f"{commit.error}; {len(commit.stored)} of {len(commit.rows)} rows were stored",
                            commit.ordered(), list(commit.stored)) from commit.error
