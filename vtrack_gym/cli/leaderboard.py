"""``vtrack leaderboard``: a stored suite's board, printed or written to ``--out`` (the store is only read)."""

from __future__ import annotations

import argparse
import os
from pathlib import Path
from typing import Any

from vtrack_gym._io import check_output_file, check_regular_input, write_atomic
from vtrack_gym.cli import _options as opt
from vtrack_gym.cli._board import ranking_note, render_board, shown_columns
from vtrack_gym.cli._terminal import err, out
from vtrack_gym.evaluation.leaderboard.html_report import MAX_FIGURE_BYTES
from vtrack_gym.evaluation.storage.store import DEFAULT_STORE_PATH

NAME = "leaderboard"
SQLITE_HEADER = b"SQLite format 3\x00"
"""The first 16 bytes of every SQLite database file."""
STORE_COMPANIONS = ("", "-wal", "-shm", "-journal")
"""Suffixes of a store's file and of the files SQLite keeps next to it."""


def register(sub: Any) -> None:
    lb = sub.add_parser(NAME, help="print the stored leaderboard",
                        description="Print the leaderboard of a suite from the store: one row per policy key (name, "
                        "preset, config or weights hash) and env, ranked by success rate, then the suite's primary "
                        "metric over successful episodes (failed episodes are counted apart); means with 95 % "
                        "bootstrap intervals (a metric missing in any episode is shown as a dash). Opens the store "
                        "read-only: it never creates or changes a file.")
    lb.add_argument("--suite", default="paper",
                    help="suite to show: one present in the store, a registered suite, custom (what `vtrack eval` "
                    "adds), tuning or tracks[...]; the command lists the store's suites (default: paper)")
    lb.add_argument("--store", type=Path, default=DEFAULT_STORE_PATH,
                    help=f"SQLite leaderboard file, opened read-only (default: {DEFAULT_STORE_PATH})")
    opt.add_format(lb, reports=True)
    opt.add_columns(lb)
    lb.add_argument("--out", type=Path, default=None,
                    help="write the leaderboard to this file (default: stdout); never the store, its -wal/-shm/"
                    "-journal files or another SQLite file")
    lb.add_argument("--figures", type=Path, default=opt.DEFAULT_FIGURES_DIR,
                    help=f"--format html: the figures root `vtrack benchmark --figures` wrote to; the report embeds "
                    f"the figures of the runs whose rows it shows, and only those (default: "
                    f"{opt.DEFAULT_FIGURES_DIR})")
    lb.add_argument("--all-versions", action="store_true",
                    help="aggregate every stored row (default: only rows of the newest package version in the "
                    "suite, the newest row per policy key, env, seed and options)")


def _same_file(a: Path, b: Path) -> bool:
    """``a`` and ``b`` are one file: the same path after resolving symlinks, or hard links of one inode."""
    if os.path.realpath(a) == os.path.realpath(b):
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:  # one of them does not exist
        return False


def check_outputs(args: argparse.Namespace) -> None:
    """``--out``: a writable regular file that is neither the store nor one of its ``-wal``/``-shm``/``-journal``
    files, and not an existing SQLite database (``ValueError`` naming --out otherwise)."""
    if args.out is None:
        return
    out_file, store = args.out, args.store
    for suffix in STORE_COMPANIONS:
        companion = store.with_name(store.name + suffix)
        if _same_file(out_file, companion):
            what = "the store" if not suffix else f"the store's {suffix[1:]} file"
            raise ValueError(f"--out {out_file} is {what} (--store {store}); `vtrack leaderboard` never changes a "
                             "store: pass another --out file (e.g. board.md), or omit --out to print to stdout")
    check_output_file(out_file, "--out")
    try:
        with open(out_file, "rb") as fh:
            header = fh.read(len(SQLITE_HEADER))
    except FileNotFoundError:
        return
    except OSError as exc:
        raise ValueError(f"--out {out_file}: cannot read the existing file ({exc.strerror or exc})") from None
    if header == SQLITE_HEADER:
        raise ValueError(f"--out {out_file} is an existing SQLite database (a store?); it is never overwritten: pass "
                         "another --out file (e.g. board.md)")


def _figures(args: argparse.Namespace, board: Any) -> tuple[list[Path], str]:
    """The PNGs ``--format html`` embeds (those of the runs whose every row the board shows:
    ``evaluation.figures.figure_runs``; regular files of at most ``MAX_FIGURE_BYTES``) and a note saying which."""
    from vtrack_gym.evaluation.figures.figure_runs import figure_runs, policy_figure_notes, run_figures
    from vtrack_gym.evaluation.leaderboard.output_formats import get_format

    if not get_format(args.format).figures:
        return [], ""
    runs = figure_runs(board.rows, board.suite_rows)
    files, missing = run_figures(args.figures, runs, MAX_FIGURE_BYTES)
    by_policy = " ".join(policy_figure_notes(board.rows, runs, missing))
    if not runs:
        return [], ("No figures: no benchmark run with figures has all of its rows on this board (figures belong to "
                    f"the run that wrote them). {by_policy}")
    note = f"Figures of {len(runs) - len(missing)} run(s) under {args.figures}: {', '.join(runs)}."
    if missing:
        note += f" Not found under --figures {args.figures}: {', '.join(missing)}."
    return files, f"{note} {by_policy}"


def run(args: argparse.Namespace) -> int:
    from vtrack_gym.evaluation.api import board_of
    from vtrack_gym.evaluation.storage.store import ResultStore

    if not args.store.exists():
        err(f"no store at {args.store}: run `vtrack benchmark` first (or pass --store)")
        return 2
    if not args.store.is_dir():  # a directory is the store's own error (StoreError)
        check_regular_input(args.store, "store (--store)")
    store = ResultStore(args.store, read_only=True)
    suites = store.suites()
    listing = ", ".join(f"{name} ({n} episodes)" for name, n in suites.items()) or "none"
    if args.suite not in suites:
        raise ValueError(f"no suite {args.suite!r} in {args.store}; suites present: {listing}. Select one with "
                         "--suite NAME")
    err(f"suite {args.suite!r} of {args.store}; suites present: {listing} (select one with --suite NAME)")
    board = board_of(store, args.suite, latest_only=not args.all_versions)
    note = ranking_note(args.suite)
    newest, hidden = store.older_versions(args.suite)
    if hidden and not args.all_versions:
        note += (f" Only rows of the newest package version ({newest}) are shown: {hidden} row(s) of older versions "
                 "are hidden; --all-versions shows them.")
    err(note)
    figures, figure_note = _figures(args, board)
    notes = [note, figure_note] if figure_note else [note]
    text = render_board(shown_columns(board.entries, args.format, args.columns, args.suite), args.format,
                        title=f"vtrack leaderboard: suite {args.suite}", figures=figures, notes=notes)
    if args.out is None:
        out(text.rstrip())
        return 0
    try:
        write_atomic(args.out, text if text.endswith("\n") else text + "\n", "--out")
    except OSError as exc:
        raise ValueError(f"cannot write --out {args.out}: {exc}") from None
    err(f"leaderboard written to {args.out}")
    return 0
