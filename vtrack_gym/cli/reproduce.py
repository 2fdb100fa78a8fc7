"""``vtrack reproduce``: rerun the paper's Case 1 and Case 2 and check its claims."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from vtrack_gym._io import check_output_dir, check_output_file
from vtrack_gym.cli import _options as opt
from vtrack_gym.cli._terminal import err, out

NAME = "reproduce"


def register(sub: Any) -> None:
    r = sub.add_parser(NAME, help="rerun the paper's Case 1 and Case 2 and check its claims",
                       description="Run PD-FLC + SMC and PD-FLC + MPC (paper presets and tuned/default presets) on "
                       "LateralTracking-v0 and DLC120-v0, write the paper-figure analogues to OUT/reproduction/ "
                       "and the claim-by-claim report OUT/REPRODUCTION.md (deterministic apart from a timestamp).")
    r.add_argument("--quick", action="store_true", help="cut every episode short (smoke test, not a reproduction)")
    r.add_argument("--out", type=Path, default=opt.DEFAULT_RESULTS_DIR,
                   help=f"output folder (default: {opt.DEFAULT_RESULTS_DIR}; `--out docs` regenerates the shipped "
                   "report)")


def needed_modules(args: argparse.Namespace) -> list[str]:
    return ["matplotlib"]


def check_outputs(args: argparse.Namespace) -> None:
    check_output_dir(args.out / "reproduction", "--out")
    check_output_file(args.out / "REPRODUCTION.md", "--out")


def run(args: argparse.Namespace) -> int:
    import time

    from vtrack_gym.evaluation.reproduction.reproduce import reproduce

    start = time.perf_counter()
    result = reproduce(args.out, quick=args.quick, progress=lambda msg: err(f"running {msg}"))
    for f in result["figures"]:
        err(f"figure: {f}")
    out(f"report: {result['report']} ({time.perf_counter() - start:.1f} s)")
    return 0
