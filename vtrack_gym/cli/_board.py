"""Leaderboards as text: the chosen format, the chosen columns, escaped for the terminal by the caller."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

TRIMMED_FORMATS = ("md", "latex")
"""Formats whose table shows the key columns unless ``--columns all`` (csv, json and html carry all)."""


def render_board(board: list[dict[str, Any]], fmt: str, title: str = "vtrack leaderboard",
                 figures: Sequence[Path] = (), notes: Sequence[str] = ()) -> str:
    """``board`` in format ``fmt`` (md, csv, json, latex, html), without a trailing newline (html as is)."""
    from vtrack_gym.evaluation import report_formats as rf

    if fmt == "html":
        from vtrack_gym.evaluation.html_report import to_html

        return to_html(board, title=title, figures=figures, notes=notes)
    return {"md": rf.to_markdown, "csv": rf.to_csv, "json": rf.to_json, "latex": rf.to_latex}[fmt](board).rstrip()


def shown_columns(board: list[dict[str, Any]], fmt: str, columns: str, suite: str) -> list[dict[str, Any]]:
    """The board a format shows: the key columns in md and latex unless ``columns`` is ``all``."""
    from vtrack_gym.evaluation.board_view import board_view
    from vtrack_gym.evaluation.suites import extra_columns, primary_metric

    return board_view(board, primary_metric(suite), columns if fmt in TRIMMED_FORMATS else "all",
                      extra_columns(suite))


def ranking_note(suite: str) -> str:
    """How ``suite``'s board is ranked (one sentence for stderr or the report)."""
    from vtrack_gym.evaluation.board import ranking_note as note
    from vtrack_gym.evaluation.suites import primary_metric

    return note(primary_metric(suite))
