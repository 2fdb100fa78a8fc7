"""``vtrack eval``: one policy on one env (or track file) for one or more seeds; rows to the store."""

from __future__ import annotations

import argparse
from typing import Any

from vtrack_gym._io import check_output_file
from vtrack_gym.cli import _options as opt
from vtrack_gym.cli._envs import announce_kernels, check_vehicle, env_or_track
from vtrack_gym.cli._extras import osqp_for
from vtrack_gym.cli._policies import parse_policy_kwargs, policy_factory
from vtrack_gym.cli._terminal import err, out

NAME = "eval"


def register(sub: Any) -> None:
    e = sub.add_parser(NAME, help="score one policy on one env", description="Run one policy on one env for one "
                       "or more seeds, print its metrics and add them to the store (suite 'custom').")
    e.add_argument("--policy", required=True,
                   help=opt.policy_help())
    opt.add_user_code(e)
    where = e.add_mutually_exclusive_group(required=True)
    where.add_argument("--env", default=None,
                       help="env id, e.g. LateralTracking-v0, DLC120-v0 or highway-env:lane-keeping-v0")
    opt.add_track(e, where=where)
    e.add_argument("--preset", default="default",
                   help="baseline preset: default (for smc and mpc the shipped GA-tuned preset), tuned, hand "
                        "(hand-tuned smc/mpc) or paper (Table 3) (default: default)")
    e.add_argument("--seeds", default="0", help="episode seeds (the env's reset seeds: each draws its own initial "
                   "offset and heading error), e.g. 0-9 or 0,3,5; one row per seed (default: 0)")
    opt.add_vehicle(e)
    opt.add_latency(e)
    opt.add_control(e)
    opt.add_numerics(e)
    opt.add_launch(e)
    opt.add_store(e)


def needed_modules(args: argparse.Namespace) -> list[str]:
    return (["highway_env"] if "highway" in (args.env or "") else []) + osqp_for([args.policy])


def check_outputs(args: argparse.Namespace) -> None:
    check_output_file(args.store, "--store", store=True)


def run(args: argparse.Namespace) -> int:
    from vtrack_gym.baselines.resolve import recorded_policy_id
    from vtrack_gym.evaluation.api import evaluate
    from vtrack_gym.evaluation.benchmarking.track_benchmark import merge_provenance
    from vtrack_gym.evaluation.identity.policy_names import user_spec_label
    from vtrack_gym.evaluation.rollouts.episode_failure import episode_of
    from vtrack_gym.evaluation.storage.commit import RowsNotStored, stored_line_of
    from vtrack_gym.evaluation.storage.store import ResultStore

    seeds = opt.parse_seeds(args.seeds)
    make = policy_factory(args.policy, args.preset, args.trust_code, parse_policy_kwargs(args.policy_kwargs))
    check_vehicle(args)   # read once: the speed-profile check, the envs and the rows use the same bytes
    env_id, provenance = env_or_track(args)
    store = ResultStore(args.store)  # verified before the rollouts
    announce_kernels()
    policy_id = user_spec_label(args.policy, parse_policy_kwargs(args.policy_kwargs)) if args.trust_code \
        else recorded_policy_id(args.policy, args.preset)   # a class of yours: its class and arguments
    try:   # each row (with its track's provenance) committed by evaluate as its episode ends, before any output
        rows = evaluate(make, env_id, seeds, store=store, policy_id=policy_id, vehicle=args.vehicle,
                        latency=args.latency, control=args.control, launch=args.launch, numerics=args.numerics,
                        finish=(lambda row: merge_provenance(row, provenance)) if provenance else None)
    except RowsNotStored as exc:   # the store failed (a full disk): the table still shows, then the error
        _print_table(exc.rows)
        raise
    except BaseException as exc:
        if episode_of(exc) is None:   # Ctrl-C, SIGTERM: an episode's own error is reported with this line
            err(f"vtrack eval: stopped; {stored_line_of(exc) or 'nothing is stored'}")
        raise
    err(f"results stored in {args.store} (suite 'custom': vtrack leaderboard --suite custom)")
    _print_table(rows)
    return 0


def _print_table(rows: list[Any]) -> None:
    """One line per seed (termination, success, float metrics) and, for several seeds, their summary."""
    from vtrack_gym.evaluation.leaderboard.report_formats import to_markdown

    table = [{"seed": r.seed, "termination": r.termination, "success": int(r.verdict()),
              **{k: v for k, v in r.metrics.items() if isinstance(v, float)},
              **({"lap_times_s": " ".join(f"{t:.3f}" for t in r.metrics["lap_times_s"]) or "-"}
                 if isinstance(r.metrics.get("lap_times_s"), list) else {})} for r in rows]
    out(to_markdown(table), flush=True)
    if len(rows) > 1:
        from vtrack_gym.evaluation.benchmarking.benchmark import LEADERBOARD_COLUMNS, summarise

        out("\n" + to_markdown(summarise(rows, LEADERBOARD_COLUMNS)), flush=True)
