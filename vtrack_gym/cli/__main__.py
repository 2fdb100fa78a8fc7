"""``python -m vtrack_gym.cli``: the ``vtrack`` command."""

import logging
import os
import sys

from vtrack_gym.cli import EXIT_INTERRUPTED, main


def exit_interrupted() -> None:
    """End the process with code 130 after Ctrl-C, through ``os._exit`` once the logs and streams are flushed.

    ``sys.exit(130)`` is not enough under ``python -m``: when the KeyboardInterrupt passed through code that an
    extension ran with ``PyRun_String`` (a Cython module's init, for one), CPython keeps a process-wide "unhandled
    Ctrl-C" flag set although ``main`` handled it, and ``python -m`` then ends the process by SIGINT instead of the
    code. ``main`` has already unwound every ``with`` and ``finally`` block (stores closed, workers shut down).
    The ``vtrack`` script exits through another path that reads no such flag.
    """
    logging.shutdown()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed reader: nothing left to deliver
            pass
    os._exit(EXIT_INTERRUPTED)


if __name__ == "__main__":
    code = main()
    if code == EXIT_INTERRUPTED:
        exit_interrupted()
    sys.exit(code)
