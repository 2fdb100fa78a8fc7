"""Leaderboards as text: the chosen format, the chosen columns, escaped for the terminal by the caller."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any


def render_board(board: list[dict[str, Any]], fmt: str, title: str = "vtrack leaderboard",
                 figures: Sequence[Path] = (), notes: Sequence[str] = ()) -> str:
    """``board`` in the registered output format ``fmt`` (``evaluation.leaderboard.output_formats``)."""
    from vtrack_gym.evaluation.leaderboard.output_formats import get_format

    return get_format(fmt).render(board, title, figures, notes)


def shown_columns(board: list[dict[str, Any]], fmt: str, columns: str, suite: str) -> list[dict[str, Any]]:
    """The board a format shows: the key columns in a trimmed format (``OutputFormat.trimmed``) unless ``columns``
    is ``all``, else every column (those explaining a verdict first in a ``key_first`` format)."""
    from vtrack_gym.evaluation.leaderboard.board_view import board_view
    from vtrack_gym.evaluation.leaderboard.output_formats import get_format
    from vtrack_gym.evaluation.suite.suites import extra_columns, primary_metric

    chosen = get_format(fmt)
    return board_view(board, primary_metric(suite), columns if chosen.trimmed else "all", extra_columns(suite),
                      ordered=chosen.key_first)


def ranking_note(suite: str) -> str:
    """How ``suite``'s board is ranked (one sentence for stderr or the report)."""
    from vtrack_gym.evaluation.leaderboard.board import ranking_note as note
    from vtrack_gym.evaluation.suite.suites import primary_metric, then_metrics

    return note(primary_metric(suite), then_metrics(suite))


EXIT_LOST = 3
"""Exit code of a run that stored every finished episode but lost some: their worker process died."""


def report_lost(lost: Sequence[str]) -> int:
    """Say under the table which episodes were lost (their worker died: nothing stored for them) and return the
    exit code: 0, or ``EXIT_LOST`` when some were."""
    from vtrack_gym.cli._terminal import err, out

    if not lost:
        return 0
    out(f"\nlost episodes: {len(lost)} (not stored; run them again)")
    for line in lost:
        out(f"- {line}")
    err(f"vtrack: {len(lost)} episodes lost (their worker process died); every finished episode was stored")
    return EXIT_LOST
