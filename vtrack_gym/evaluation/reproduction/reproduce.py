"""Reproduce the paper's results section (issue 8): what ``vtrack reproduce`` runs.

Case 1 (``LateralTracking-v0``: 0 -> 40 km/h on the handling course) and Case 2 (``DLC120-v0``: double lane
change at 120 km/h), each with PD-FLC + SMC and PD-FLC + MPC, for two preset pairs:

- ``paper``: SMC preset ``paper`` (Table 3) vs MPC preset ``paper`` (Table 3 weights);
- ``tuned``: SMC preset ``tuned`` vs MPC preset ``tuned`` (the shipped GA results, also the ``default`` presets);
- ``hand``: SMC preset ``hand`` vs MPC preset ``hand`` (the hand-tuned configs).

Writes the paper-figure analogues (Figs. 8-13 for Case 1, 15-19 for Case 2) as PNG files and a Markdown report
that checks every quantitative claim of the paper. The report is deterministic: apart from its ``Generated:``
line it depends only on the simulation results (no wall times, fixed float formatting).

This module only ties the two jobs together: ``reproduce_runs`` runs the episodes and draws the figures,
``reproduce_report`` writes the prose.
"""

from __future__ import annotations

import datetime as _dt
from collections.abc import Callable
from pathlib import Path
from typing import Any

from vtrack_gym._io import write_atomic
from vtrack_gym.evaluation.reproduction.reproduce_report import CLAIMS, CORRECTIONS, TIMESTAMP_PREFIX, build_report
from vtrack_gym.evaluation.reproduction.reproduce_runs import CASES, PAIRS, QUICK_MAX_STEPS, Run, run_all, write_figures

__all__ = ["CASES", "CLAIMS", "CORRECTIONS", "PAIRS", "QUICK_MAX_STEPS", "TIMESTAMP_PREFIX", "Run", "reproduce"]


def reproduce(out_dir: str | Path = "docs", quick: bool = False, figures: bool = True,
              progress: Callable[[str], None] | None = None) -> dict[str, Any]:
    """Run every episode, write ``<out_dir>/reproduction/*.png`` and ``<out_dir>/REPRODUCTION.md``.

    Returns ``{"report": path, "figures": [paths], "runs": {(policy, preset, env_id): Run}}``.
    """
    out = Path(out_dir)
    runs = run_all(quick, progress)
    files = write_figures(runs, out / "reproduction") if figures else []
    stamp = _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M:%S UTC")
    report = out / "REPRODUCTION.md"
    out.mkdir(parents=True, exist_ok=True)
    write_atomic(report, build_report(runs, files, quick, stamp), "--out")
    return {"report": report, "figures": files, "runs": runs}
