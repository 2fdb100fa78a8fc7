"""Where stable-baselines3 writes its training log: inside a run folder, or nowhere.

Without a logger set, SB3's ``learn()`` makes its default one, and with it a folder ``SB3-<date and time>`` in the
temporary directory (``$TMPDIR``) on every call, left behind empty when nothing is asked to be written.
``run_logger`` writes into a run folder's ``logs/`` (TensorBoard if installed, CSV and text); ``quiet_logger``
writes no file and makes no folder (the text table on stdout with ``verbose >= 1``, as SB3's default shows it).
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any


def run_logger(folder: Path) -> Any:
    """An SB3 logger writing into ``folder`` (made if missing): TensorBoard events if tensorboard is installed, a
    CSV table and a text log."""
    from stable_baselines3.common.logger import configure

    try:
        import tensorboard  # noqa: F401

        formats = ["tensorboard", "csv", "log"]
    except ImportError:
        formats = ["csv", "log"]
    return configure(str(folder), formats)


def quiet_logger(verbose: int = 0) -> Any:
    """An SB3 logger without a folder: the text table on stdout when ``verbose >= 1``, else nothing."""
    from stable_baselines3.common.logger import HumanOutputFormat, Logger

    return Logger(folder=None, output_formats=[HumanOutputFormat(sys.stdout)] if verbose >= 1 else [])


def log_outside_tmp(model: Any, run_dir: Path | None = None) -> None:
    """Give ``model`` (an SB3 algorithm, before ``learn``) a logger that leaves nothing in the temporary directory:
    ``run_dir/logs`` with a run folder, else ``quiet_logger``. A model given ``tensorboard_log`` (a folder of the
    caller's) keeps SB3's own logger, which writes there."""
    if run_dir is not None:
        model.set_logger(run_logger(run_dir / "logs"))
    elif getattr(model, "tensorboard_log", None) is None:
        model.set_logger(quiet_logger(int(getattr(model, "verbose", 0))))
