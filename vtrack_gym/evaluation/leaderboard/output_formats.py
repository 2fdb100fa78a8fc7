"""The leaderboard output formats in one registry: name, description, how to render a board and which columns the
format shows. ``vtrack benchmark --format`` and ``vtrack leaderboard --format`` (choices and help) read it.

An output format of your own is one ``OutputFormat`` and one ``register_format`` call (or, in the package, one
entry of ``_FORMATS``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

Renderer = Callable[[list[dict[str, Any]], str, Sequence[Path], Sequence[str]], str]
"""``render(board, title, figures, notes) -> text``."""


@dataclass(frozen=True)
class OutputFormat:
    """One leaderboard output format: ``render(board, title, figures, notes)``; ``trimmed``: shows the key columns
    unless ``--columns all`` (else every column); ``report``: a document for ``vtrack leaderboard`` only (not
    streamed by ``vtrack benchmark``); ``figures``: embeds the figures of the runs on the board; ``key_first``:
    every column, those that rank and explain a verdict (``board_view.key_view``) first."""

    name: str
    description: str
    render: Renderer
    trimmed: bool = False
    report: bool = False
    figures: bool = False
    key_first: bool = False

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.isidentifier():
            raise ValueError(f"OutputFormat.name must be an identifier such as md (got {self.name!r})")
        if not callable(self.render):
            raise ValueError(f"OutputFormat.render must be callable (got {self.render!r})")


def _table(name: str) -> Renderer:
    """A ``report_formats.to_<name>`` table, titles, figures and notes dropped."""
    def render(board: list[dict[str, Any]], title: str, figures: Sequence[Path], notes: Sequence[str]) -> str:
        from vtrack_gym.evaluation.leaderboard import report_formats

        return getattr(report_formats, f"to_{name}")(board).rstrip()
    return render


def _html(board: list[dict[str, Any]], title: str, figures: Sequence[Path], notes: Sequence[str]) -> str:
    from vtrack_gym.evaluation.leaderboard.html_report import to_html

    return to_html(board, title=title, figures=figures, notes=notes)


_FORMATS: dict[str, OutputFormat] = {f.name: f for f in (
    OutputFormat("md", "Markdown table", _table("markdown"), trimmed=True),
    OutputFormat("csv", "CSV", _table("csv")),
    OutputFormat("json", "JSON", _table("json")),
    OutputFormat("latex", "LaTeX booktabs tabular", _table("latex"), trimmed=True, report=True),
    OutputFormat("html", "self-contained HTML report (sortable table, figures embedded, no network)", _html,
                 report=True, figures=True, key_first=True),
)}


def register_format(fmt: OutputFormat, replace: bool = False) -> OutputFormat:
    """Add ``fmt`` to the registry (``replace``: over a format of the same name); returns it."""
    from vtrack_gym._plugins import add_named

    return add_named(_FORMATS, getattr(fmt, "name", ""), fmt, OutputFormat, "output format", replace)


def unregister_format(name: str) -> None:
    """Remove the format ``name`` (a no-op for an unknown name)."""
    _FORMATS.pop(name, None)


def format_names(reports: bool = True) -> tuple[str, ...]:
    """Every registered format (``reports=False``: without the report-only ones)."""
    return tuple(n for n, f in _FORMATS.items() if reports or not f.report)


def get_format(name: str) -> OutputFormat:
    """The registered format ``name`` (``ValueError`` listing the registered ones otherwise)."""
    try:
        return _FORMATS[name]
    except (KeyError, TypeError):
        raise ValueError(f"unknown output format {name!r}; valid: {', '.join(_FORMATS)}") from None


def formats_help(names: Sequence[str]) -> str:
    """``md (Markdown table), csv (CSV), ...`` for ``--help`` texts."""
    return ", ".join(f"{n} ({get_format(n).description})" for n in names)
