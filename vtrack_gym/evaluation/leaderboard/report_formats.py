"""Leaderboard text formats: Markdown, CSV, JSON and LaTeX (booktabs), each escaping ids and notes.

A board is a list of dicts with the same keys (see ``vtrack_gym.evaluation.leaderboard.board.build_board``). Strings
come from stores that may have been written by someone else, so every format treats them as data:

* Markdown: control characters are shown as escapes (``\\n``), Markdown/HTML punctuation is backslash-escaped
  (``_`` only where it could start or end emphasis), so an id with a newline and pipes stays one cell of one row;
* CSV: quoting by the csv module, and a cell starting with ``= + - @``, a tab or a carriage return (also after
  leading blanks) is prefixed with ``'`` so spreadsheets do not run it as a formula; NaN is an empty cell;
* JSON: NaN/inf as ``null``;
* LaTeX: the ten special characters and ``| < >`` escaped, control characters shown as escapes.

Confidence intervals (``vtrack_gym.evaluation.leaderboard.board.Estimate`` values): Markdown, LaTeX and HTML show one
cell ``mean [lo, hi]`` (the bare mean when the interval is undefined); CSV and JSON give three columns ``name``,
``name_lo``, ``name_hi``.
"""

from __future__ import annotations

import csv
import io
import json
import math
import re
from collections.abc import Callable
from typing import Any

from vtrack_gym.evaluation.leaderboard.board import Estimate, metric_value

_CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f\u2028\u2029]")
_MD_SPECIAL = re.compile(r"([\\`*\[\]<>|~&#!]|(?<![A-Za-z0-9])_|_(?![A-Za-z0-9]))")  # intraword _ is inert
_CSV_FORMULA_START = ("=", "+", "-", "@", "\t", "\r", "\uff1d", "\uff0b", "\uff0d", "\uff20")
_LATEX_SPECIAL = {"\\": r"\textbackslash{}", "&": r"\&", "%": r"\%", "$": r"\$", "#": r"\#", "_": r"\_",
                  "{": r"\{", "}": r"\}", "~": r"\textasciitilde{}", "^": r"\textasciicircum{}",
                  "|": r"\textbar{}", "<": r"\textless{}", ">": r"\textgreater{}"}


def visible_controls(text: str) -> str:
    """``text`` with every control character (newline, tab, NUL, line separators) as a Python-style escape."""
    return _CONTROL.sub(lambda m: m.group().encode("unicode_escape").decode("ascii"), text)


def format_number(value: float, digits: int = 3) -> str:
    """``value`` with ``digits`` significant digits (integers as integers)."""
    if isinstance(value, int) and not isinstance(value, bool):
        return str(value)
    return f"{value:.{digits}g}"


def format_estimate(value: float, digits: int = 3) -> str:
    """``mean [lo, hi]`` of an ``Estimate`` (the bare mean when its interval is undefined or it is a float)."""
    text = format_number(value, digits)
    if isinstance(value, Estimate) and math.isfinite(value.lo) and math.isfinite(value.hi):
        text += f" [{format_number(value.lo, digits)}, {format_number(value.hi, digits)}]"
    return text


def expand_estimates(entry: dict[str, Any]) -> dict[str, Any]:
    """``entry`` with every ``Estimate`` as three plain numbers ``name``, ``name_lo``, ``name_hi`` (CSV, JSON)."""
    out: dict[str, Any] = {}
    for k, v in entry.items():
        if isinstance(v, Estimate):
            out[k], out[f"{k}_lo"], out[f"{k}_hi"] = float(v), v.lo, v.hi
        else:
            out[k] = v
    return out


def _is_missing(value: Any) -> bool:
    return (isinstance(value, float) and not math.isfinite(value)) or value is None


def _text_cells(entry: dict[str, Any], cols: list[str], digits: int, missing: str,
                escape: Callable[[str], str]) -> list[str]:
    """Cells of one row: ``missing`` for NaN/None, numbers with ``digits`` significant digits, text escaped."""
    cells = []
    for c in cols:
        v = entry[c]
        if _is_missing(v):
            cells.append(missing)
        elif isinstance(v, (int, float)) and not isinstance(v, bool):
            cells.append(format_estimate(v, digits))
        else:
            cells.append(escape(str(v)))
    return cells


def markdown_escape(text: str) -> str:
    """One Markdown table cell showing ``text`` literally (no row breaks, pipes, links, HTML or emphasis)."""
    return _MD_SPECIAL.sub(r"\\\1", visible_controls(text))


def to_markdown(board: list[dict[str, Any]], digits: int = 3) -> str:
    """A GitHub-flavoured Markdown table of a leaderboard (missing values as ``–``)."""
    if not board:
        return "(no results)"
    cols = list(board[0])
    lines = ["| " + " | ".join(markdown_escape(c) for c in cols) + " |", "|" + "|".join("---" for _ in cols) + "|"]
    for entry in board:
        lines.append("| " + " | ".join(_text_cells(entry, cols, digits, "–", markdown_escape)) + " |")
    return "\n".join(lines)


def csv_cell(value: Any) -> Any:
    """A CSV cell: numbers as they are (NaN empty), text with a formula-starting character neutralised."""
    if _is_missing(value):
        return ""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return value
    text = str(value)
    if text.lstrip(" ").startswith(_CSV_FORMULA_START):
        return "'" + text
    return text


def to_csv(board: list[dict[str, Any]]) -> str:
    """CSV text of a leaderboard (header row first; see the module docstring for the escaping)."""
    buf = io.StringIO()
    if board:
        board = [expand_estimates(e) for e in board]
        cols = list(board[0])
        writer = csv.writer(buf, lineterminator="\n")
        writer.writerow([csv_cell(c) for c in cols])
        for entry in board:
            writer.writerow([csv_cell(entry[c]) for c in cols])
    return buf.getvalue()


def json_value(value: Any) -> Any:
    """A JSON-safe scalar: NaN/inf as None, numpy scalars as Python numbers."""
    if value is None or isinstance(value, str):
        return value
    if isinstance(value, (int, float, bool)) or hasattr(value, "item"):
        number = metric_value(value)
        if number is None:
            return None
        return value.item() if hasattr(value, "item") else value
    return value


def to_json(board: list[dict[str, Any]]) -> str:
    """JSON text of a leaderboard (a list of objects; NaN as null)."""
    return json.dumps([{k: json_value(v) for k, v in expand_estimates(e).items()} for e in board], indent=2,
                      allow_nan=False)


def latex_escape(text: str) -> str:
    """``text`` safe inside a LaTeX tabular cell."""
    return "".join(_LATEX_SPECIAL.get(ch, ch) for ch in visible_controls(text))


def to_latex(board: list[dict[str, Any]], digits: int = 3) -> str:
    """A ``booktabs`` tabular of a leaderboard (needs ``\\usepackage{booktabs}``; missing values as ``--``)."""
    if not board:
        return "% (no results)"
    cols = list(board[0])
    numeric = [all(isinstance(e[c], (int, float)) and not isinstance(e[c], bool) for e in board) for c in cols]
    spec = "".join("r" if n else "l" for n in numeric)
    lines = [f"\\begin{{tabular}}{{{spec}}}", r"\toprule",
             " & ".join(latex_escape(c) for c in cols) + r" \\", r"\midrule"]
    for entry in board:
        lines.append(" & ".join(_text_cells(entry, cols, digits, "--", latex_escape)) + r" \\")
    lines += [r"\bottomrule", r"\end{tabular}"]
    return "\n".join(lines)
