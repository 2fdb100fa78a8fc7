"""The ``vtrack`` command (the only place that parses argv; it parses and prints, the library does the work).

    vtrack benchmark            every baseline (and shipped agent) on the paper suite -> leaderboard + figures
    vtrack eval --policy mpc --env DLC120-v0
    vtrack leaderboard --suite paper --format md
    vtrack plot --policies smc,mpc --env LateralTracking-v0
    vtrack tune --controller smc --budget paper --space working --out smc_tuned.json
    vtrack video --policy mpc --env DLC120-v0 --out dlc.mp4
    vtrack dataset --policy mpc --suite paper --episodes 2
    vtrack entry-speed --policy mpc --env vtrack/ISO3888-2-v1
    vtrack lap-bound --track handling_course --plot lap.png

One module per command (``evaluate`` runs ``vtrack eval``, ``entry_speed`` ``vtrack entry-speed``): ``register``
adds its subparser, ``run`` runs it, ``needed_modules`` and ``check_outputs`` say which optional packages and
outputs it has. Shared options live in
``_options``; everything written to the terminal goes through ``_terminal`` (escaped).
"""

from __future__ import annotations

import argparse
import contextlib
import logging
import os
import signal
import sqlite3
import sys
import threading
from collections.abc import Iterator, Sequence
from types import ModuleType
from typing import Any

from vtrack_gym.cli import (
    _board,
    benchmark,
    dataset,
    entry_speed,
    evaluate,
    export,
    lap_bound,
    leaderboard,
    plot,
    reproduce,
    train,
    tune,
    video,
)
from vtrack_gym.cli._extras import missing_packages
from vtrack_gym.cli._options import Parser
from vtrack_gym.cli._terminal import SafeFormatter, err, results_only_on_stdout, safe_warnings
from vtrack_gym.evaluation.storage.store import StoreError
from vtrack_gym.tuning.backends import BackendError

COMMANDS: tuple[ModuleType, ...] = (benchmark, evaluate, leaderboard, train, export, plot, tune, video, reproduce,
                                    dataset, entry_speed, lap_bound)
"""The command modules, in the order ``vtrack --help`` lists them."""
EXIT_ERROR = 2
"""Exit code of a refused command (bad input, unusable file, missing package) and of a run stopped by an error in
an episode (a policy that raised; the episodes that finished are stored)."""
EXIT_INTERRUPTED = 130
"""Exit code after Ctrl-C (128 + SIGINT)."""
EXIT_BROKEN_PIPE = 141
"""Exit code when the reader of stdout went away, e.g. ``vtrack leaderboard | head -1`` (128 + SIGPIPE)."""
EXIT_TERMINATED = 143
"""Exit code after SIGTERM (128 + SIGTERM): the command stopped its workers and kept what it had stored."""
EXIT_LOST = _board.EXIT_LOST
"""Exit code of a run that lost episodes (their worker process died) and stored every other one."""


class _Terminated(BaseException):
    """SIGTERM, raised where the command is so that its ``finally`` blocks stop its workers (not an ``Exception``:
    no handler of the command swallows it)."""


def _on_sigterm(signum: int, frame: Any) -> None:
    raise _Terminated()


@contextlib.contextmanager
def _sigterm_ends_the_command() -> Iterator[None]:
    """While a command runs in the main thread, SIGTERM unwinds it (workers stopped, stores closed) instead of
    killing the process on the spot."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGTERM, _on_sigterm)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)
_EXPECTED = (ValueError, FileNotFoundError, ImportError, StoreError, sqlite3.Error, BackendError)
"""Errors a command reports in one line (anything else is a bug and keeps its traceback)."""


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``vtrack`` (every option explained in --help)."""
    parser = Parser(prog="vtrack", description="Benchmark steering controllers and RL agents on "
                    "the paper's trajectory-tracking scenarios.")
    for where in (parser, *_command_parsers(parser)):  # global options: before or after the command
        where.add_argument("-v", "--verbose", action="store_true",
                           default=False if where is parser else argparse.SUPPRESS,
                           help="log details to stderr: every episode's result, the kernel cache (the long phases "
                           "are always announced)")
    return parser


def _command_parsers(parser: argparse.ArgumentParser) -> list[argparse.ArgumentParser]:
    """The subparser of every command (registered on ``parser``)."""
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for command in COMMANDS:
        command.register(sub)
    return list(sub.choices.values())


def _setup_logging(verbose: bool) -> None:
    """Warnings and above to stderr, escaped; the package says what its long phases do (INFO), ``-v`` adds every
    episode's result and the details (DEBUG)."""
    root = logging.getLogger()
    if not root.handlers:
        handler = logging.StreamHandler()
        handler.setFormatter(SafeFormatter("%(levelname)s %(message)s"))
        root.addHandler(handler)
        root.setLevel(logging.WARNING)
    logging.getLogger("vtrack_gym").setLevel(logging.DEBUG if verbose else logging.INFO)


def _run(command: ModuleType, args: argparse.Namespace) -> int:
    """Check the command's optional packages and outputs, then run it; a refusal is one line and exit code 2."""
    from tqdm.contrib.logging import logging_redirect_tqdm

    missing = missing_packages(args, getattr(command, "needed_modules", lambda a: []))
    if missing:
        err(f"vtrack {args.command}: error: {missing}")
        return EXIT_ERROR
    try:
        check_outputs = getattr(command, "check_outputs", None)
        if check_outputs is not None:
            check_outputs(args)  # every output checked (missing folders created) before any work starts
        with logging_redirect_tqdm():  # log lines printed above the progress bars, not through them
            return command.run(args)
    except Exception as exc:
        line = _failure_line(exc)
        if line is None:
            raise   # a bug: its traceback
        err(f"vtrack {args.command}: error: {line}")
        return EXIT_ERROR


def _failure_line(exc: Exception) -> str | None:
    """The one line a command's error is reported in: an expected error's message, or an error raised in an episode
    (a policy that raised) with its episode and what the run stored (the traceback under ``-v``); None for anything
    else (a bug keeps its traceback)."""
    from vtrack_gym.evaluation.rollouts.episode_failure import failure_line
    from vtrack_gym.evaluation.storage.commit import stored_line_of

    line = failure_line(exc)
    if line is None:
        return str(exc) if isinstance(exc, _EXPECTED) else None
    logging.getLogger("vtrack_gym.cli").debug("the failed episode's traceback", exc_info=exc)
    stored = stored_line_of(exc)
    return f"{line}; {stored}" + ("" if logging.getLogger("vtrack_gym").isEnabledFor(logging.DEBUG)
                                  else " (-v shows the traceback)")


def _silence_stdout() -> None:
    """Point stdout at /dev/null, so the interpreter's last flush to a closed pipe raises nothing."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):  # not a real file (a test's capture): nothing to flush
        pass


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``vtrack``; returns the process exit code (130 after Ctrl-C, 141 on a closed stdout)."""
    try:
        args = build_parser().parse_args(argv)
        args.argv = None if argv is None else list(argv)
        _setup_logging(args.verbose)
        import vtrack_gym  # noqa: F401  (registers the env ids)

        commands = {c.NAME: c for c in COMMANDS}
        with safe_warnings(), _sigterm_ends_the_command(), results_only_on_stdout():
            code = _run(commands[args.command], args)
        sys.stdout.flush()
        return code
    except KeyboardInterrupt:
        err("vtrack: interrupted (Ctrl-C)")
        return EXIT_INTERRUPTED
    except _Terminated:
        err("vtrack: terminated (SIGTERM); the finished episodes are stored")
        return EXIT_TERMINATED
    except BrokenPipeError:
        _silence_stdout()
        return EXIT_BROKEN_PIPE


if __name__ == "__main__":
    sys.exit(main())
