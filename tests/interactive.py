"""Start a command as a terminal would: with Ctrl-C (SIGINT) at its default disposition.

A process started with SIGINT ignored keeps it ignored, and Python then installs no ``KeyboardInterrupt`` handler:
so it is for every child of a test run started in the background by a shell without job control (``pytest &`` in
a script, ``nohup``, some CI runners). A test that sends SIGINT to ``vtrack`` to stand for a user's Ctrl-C starts
it through ``as_in_a_terminal``, so the signal means there what it means at a terminal.
"""

from __future__ import annotations

import sys

_RESTORE_THEN_EXEC = ("import os, signal, sys; signal.signal(signal.SIGINT, signal.SIG_DFL); "
                      "os.execv(sys.argv[1], sys.argv[1:])")


def as_in_a_terminal(argv: list[str]) -> list[str]:
    """``argv`` (its first item the program) run with SIGINT's default disposition restored before ``exec``: the
    same process id, so a signal sent to the ``Popen`` reaches the command itself."""
    return [sys.executable, "-c", _RESTORE_THEN_EXEC, *argv]
