"""``vtrack tune``: GA-tune a tunable controller (its own spaces and budgets) and write a tuned preset (JSON)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from vtrack_gym._io import check_output_file
from vtrack_gym.baselines.registry import tunable_policies
from vtrack_gym.cli import _options as opt
from vtrack_gym.cli._envs import env_or_track
from vtrack_gym.cli._terminal import err, out

NAME = "tune"


def register(sub: Any) -> None:
    from vtrack_gym.tuning.spaces import declared_help, declared_names

    t = sub.add_parser(NAME, help=f"GA-tune a controller ({', '.join(tunable_policies())}) on Case 1 and write a "
                       "tuned preset (JSON)",
                       description="Genetic algorithm (pymoo: rank selection, SBX 0.8, polynomial mutation 0.1) "
                       "minimising ITAE + constraint penalties on LateralTracking-v0. Each generation runs as one "
                       "batched rollout, in this process or (--backend ray) split over a Ray cluster's workers, with a "
                       "bit-identical result. Writes a JSON preset with provenance.")
    t.add_argument("--controller", choices=tunable_policies(), required=True, help="controller to tune")
    t.add_argument("--budget", choices=declared_names("budgets"), default=None,
                   help=f"GA budget (generations x population) the controller declares: {declared_help('budgets')} "
                   "(default: the controller's first; paper is Table 2)")
    t.add_argument("--space", choices=declared_names("spaces"), default=None,
                   help=f"search space the controller declares: {declared_help('spaces')} (default: the "
                   "controller's first; paper is Table 2's bounds)")
    t.add_argument("--generations", type=opt.int_in(1, 10_000), default=None,
                   help="override the budget's generations (1-10000)")
    t.add_argument("--pop-size", type=opt.int_in(2, 10_000), default=None,
                   help="override the budget's population size (2-10000)")
    t.add_argument("--seed", "--rng-seed", dest="seed", type=opt.int_in(0, opt.MAX_RNG_SEED), default=0,
                   help="random seed of the genetic algorithm, 0 to 2^32-1: its initial population, selection, "
                   "crossover and mutation (the scenario is the nominal one, not drawn from a seed) (default: 0)")
    t.add_argument("--comfort-weight", type=opt.float_in(0.0, 1e6), default=0.0,
                   help="weight of the ISO 2631-1 comfort a_v in the fitness (default: 0 = off)")
    t.add_argument("--out", type=Path, default=None,
                   help="preset file to write (default: vtrack_results/<controller>_tuned.json)")
    t.add_argument("--store", type=Path, default=None,
                   help="also record the result in this leaderboard store (suite 'tuning'; default: none)")
    t.add_argument("--also-complete", default="",
                   help="comma-separated env ids every individual must also complete, e.g. DLC120-v0 (a failure "
                   "adds the incomplete-run penalty; default: none, the paper's Case-1-only fitness)")
    opt.add_track(t, "a CSV track file every individual must also complete (like --also-complete; local backend)")
    t.add_argument("--max-steps", type=opt.int_in(1, 10**7), default=None,
                   help="cut every episode after this many steps (smoke tests only; default: full episodes)")
    t.add_argument("--backend", choices=("local", "ray"), default="local",
                   help="where each generation is evaluated: local (one batched rollout in this process) or ray "
                   "(the population split over Ray workers; needs pip install \"vtrack_gym[ray]\"; same result) "
                   "(default: local)")
    t.add_argument("--ray-address", default=None, metavar="ADDR",
                   help="Ray cluster to connect to with --backend ray, e.g. 10.0.0.5:6379 (default: $RAY_ADDRESS "
                   "if set, else a local Ray instance started and stopped by this command)")
    t.add_argument("--workers", type=opt.int_in(1, opt.MAX_WORKERS), default=None, metavar="N",
                   help="Ray workers with --backend ray (default: the cluster's CPU count, at most the population "
                   "size)")
    t.add_argument("--no-progress", action="store_true", help="no progress bar")


def needed_modules(args: argparse.Namespace) -> list[str]:
    return ["pymoo"]


def check_outputs(args: argparse.Namespace) -> None:
    check_output_file(args.out or opt.DEFAULT_RESULTS_DIR / f"{args.controller}_tuned.json", "--out")
    if args.store is not None:
        check_output_file(args.store, "--store", store=True)


def run(args: argparse.Namespace) -> int:
    import json
    import shlex

    from vtrack_gym.tuning.job import tune_to_preset

    if args.backend != "ray" and (args.ray_address is not None or args.workers is not None):
        raise ValueError("--ray-address and --workers need --backend ray")
    also = [e for e in args.also_complete.split(",") if e]
    if args.track is not None:  # every individual must also complete the track (ids of this process: local only)
        if args.backend == "ray":
            raise ValueError("--track needs --backend local (the track's env id is registered in this process)")
        also.append(env_or_track(args)[0])
    command = "vtrack " + " ".join(shlex.quote(a) for a in (sys.argv[1:] if args.argv is None else args.argv))
    outcome = tune_to_preset(
        args.controller, args.space, args.budget, seed=args.seed, generations=args.generations,
        pop_size=args.pop_size, comfort_weight=args.comfort_weight, max_steps=args.max_steps,
        also_complete=tuple(also), backend=args.backend,
        ray_address=args.ray_address, num_workers=args.workers, out=args.out, store=args.store, command=command,
        progress=not args.no_progress)
    result = outcome.result
    out(json.dumps({"best_fitness": result.best_fitness, "initial_best_fitness": result.initial_best_fitness,
                    "params": result.params, **result.best_metrics}, indent=2))
    where = f" on {result.workers} Ray workers" if result.backend == "ray" else ""
    err(f"{result.episodes} episodes in {result.wall_s:.1f} s{where} ({outcome.episodes_per_s:.2f} episodes/s); "
        f"preset written to {outcome.preset_file}")
    if args.store is not None:
        err(f"result stored in {args.store} (suite 'tuning')")
    return 0
