"""``vtrack plot``: the paper's figures for some policies on one env (the benchmark's figures are left alone)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from vtrack_gym._io import check_output_dir
from vtrack_gym.cli import _options as opt
from vtrack_gym.cli._envs import announce_kernels, env_or_track
from vtrack_gym.cli._extras import osqp_for
from vtrack_gym.cli._policies import policy_makers
from vtrack_gym.cli._terminal import out

NAME = "plot"


def register(sub: Any) -> None:
    pl = sub.add_parser(NAME, help="write the paper's figures for some policies",
                        description="Roll out the given policies on one env and write trajectory, signal and "
                        "deviation-rate figures.")
    pl.add_argument("--policies", default="smc,mpc", help="comma-separated policy names (default: smc,mpc)")
    opt.add_user_code(pl)
    pl.add_argument("--env", default=None,
                    help="env id, also highway-env:lane-keeping-v0 (default: LateralTracking-v0, or --track)")
    opt.add_track(pl)
    pl.add_argument("--out", type=Path, default=opt.DEFAULT_PLOTS_DIR,
                    help=f"output folder (default: {opt.DEFAULT_PLOTS_DIR}; the benchmark's figures are left alone)")


def needed_modules(args: argparse.Namespace) -> list[str]:
    needed = ["matplotlib"] + (["highway_env"] if "highway" in (args.env or "") else [])
    return needed + osqp_for(opt.policy_list(args.policies))


def check_outputs(args: argparse.Namespace) -> None:
    check_output_dir(args.out, "--out")


def run(args: argparse.Namespace) -> int:
    from vtrack_gym.evaluation.benchmarking.benchmark import score_policy, write_figures
    from vtrack_gym.evaluation.suite.suites import Episode

    env_id, _ = env_or_track(args, default="LateralTracking-v0")
    names = opt.policy_list(args.policies)
    if not names:
        raise ValueError("--policies needs at least one policy name, e.g. --policies smc,mpc")
    makes = dict(policy_makers(names, "default", args.trust_code, args.policy_kwargs))  # checked before any rollout
    announce_kernels()
    rows, traces = [], []
    for name, make in makes.items():
        r, t = score_policy(name, make, [Episode(env_id, 0)], "custom")
        rows += r
        traces += t
    for f in write_figures({env_id: traces}, rows, args.out):
        out(f"figure: {f}")
    return 0
