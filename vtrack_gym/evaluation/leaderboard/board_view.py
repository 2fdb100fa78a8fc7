"""Which leaderboard columns a reader sees first: the key columns of a board (the full board keeps them all).

A board entry (``vtrack_gym.evaluation.leaderboard.board.build_board``) has some 25 columns; a terminal shows the few
that rank and explain it. Metric values keep their ``Estimate`` type, so a format shows their intervals.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

KEY_COLUMNS: tuple[str, ...] = ("env_id", "policy_id", "rank", "success_rate", "max_e_y_m", "rms_e_y_m")
"""Always shown: where, who, the rank, the success rate and the lateral error's peak and RMS [m]."""
EXPLAIN_COLUMNS: tuple[str, ...] = ("failure_reasons",)
"""Shown after the primary metric: why the failed episodes failed."""
COLUMN_SETS: tuple[str, ...] = ("key", "all")
"""``key``: ``key_view``; ``all``: every column of the board."""


def key_view(board: Sequence[dict[str, Any]], primary: str, suite_columns: Sequence[str] = ()) -> list[dict[str, Any]]:
    """``board`` with only its key columns: ``KEY_COLUMNS``, the suite's ``primary`` metric (with its interval) when
    it is not one of them, the columns only this suite has (``suite_columns``, e.g. the ISO 4138 circle's lateral
    acceleration) and ``EXPLAIN_COLUMNS``; columns a board lacks are left out. Two entries of one env with one
    policy id are shown by their ``name`` (``policy_id@policy_hash``)."""
    wanted = list(dict.fromkeys([*KEY_COLUMNS, primary, *suite_columns, *EXPLAIN_COLUMNS]))
    return [{c: (_shown_id(entry) if c == "policy_id" else entry[c]) for c in wanted if c in entry}
            for entry in board]


def _shown_id(entry: dict[str, Any]) -> Any:
    """The policy as a reader tells it apart: ``name`` (``policy_id@policy_hash``) where two entries of an env
    share a policy id (two agent files with one stem, one class with two settings), else ``policy_id``."""
    name = entry.get("name")
    return name if isinstance(name, str) and name.endswith(f"@{entry.get('policy_hash')}") else entry["policy_id"]


def key_first(board: Sequence[dict[str, Any]], primary: str, suite_columns: Sequence[str] = ()) -> list[dict[str, Any]]:
    """Every column of ``board``, the ``key_view`` ones (which rank and explain a verdict: the success rate, the
    primary metric, ``failure_reasons``) first."""
    keys = key_view(board, primary, suite_columns)
    return [{**k, **{c: v for c, v in entry.items() if c not in k}} for k, entry in zip(keys, board, strict=True)]


def board_view(board: Sequence[dict[str, Any]], primary: str, columns: str = "key",
               suite_columns: Sequence[str] = (), ordered: bool = False) -> list[dict[str, Any]]:
    """The columns of ``board`` named by ``columns`` (``COLUMN_SETS``; ``key``: ``key_view``; ``all`` with
    ``ordered``: ``key_first``); ``ValueError`` for another value."""
    if columns not in COLUMN_SETS:
        raise ValueError(f"columns must be one of {', '.join(COLUMN_SETS)} (got {columns!r})")
    if columns == "all":
        return key_first(board, primary, suite_columns) if ordered else list(board)
    return key_view(board, primary, suite_columns)
