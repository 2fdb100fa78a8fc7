"""``vtrack train``: train an RL steering agent with stable-baselines3 and export it."""

from __future__ import annotations

import argparse
import re
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from vtrack_gym._io import check_output_dir, check_output_file
from vtrack_gym.cli import _options as opt
from vtrack_gym.cli._terminal import err, out

NAME = "train"


def register(sub: Any) -> None:
    tr = sub.add_parser(NAME, help="train an RL steering agent with stable-baselines3 (extra 'rl')",
                        description="Train PPO/SAC/TD3 on the native vector env (the training mix by default) with "
                        "the versioned hyperparameters of vtrack_gym/agents/hyperparams, evaluate on both paper "
                        "scenarios periodically, and export a weights-only agent (agent.json + agent.npz) that "
                        "`vtrack eval` and the benchmark load without torch.")
    tr.add_argument("--algo", choices=("ppo", "sac", "td3", "dagger"), required=True,
                    help="SB3 algorithm, or dagger: dataset aggregation of --bc-expert's labels into a small MLP "
                    "agent, no RL update (vtrack/Race-v0: on the race split's training circuits)")
    tr.add_argument("--env", default=None,
                    help="training env id (default: vtrack/TrainingMix20Hz-v0, the from-scratch recipes' training "
                    "mix at 20 Hz decisions; with --bc-expert: LateralTrackingRandom-v0, the imitation recipes')")
    tr.add_argument("--timesteps", type=opt.int_in(1, 10**10), default=None,
                    help="environment steps (default: the hyperparameter entry's n_timesteps)")
    tr.add_argument("--seed", "--rng-seed", dest="seed", type=opt.int_in(0, opt.MAX_RNG_SEED), default=0,
                    help="random seed of the training run, 0 to 2^32-1: the network's initial weights, the "
                    "exploration and the training envs' episode draws (not an episode seed of the scoring; the "
                    "periodic evaluations use episode seed 0) (default: 0)")
    tr.add_argument("--run-dir", type=Path, required=True, help="folder for config, logs, checkpoints and the agent "
                    "(a folder that already holds a run is refused, see --overwrite)")
    tr.add_argument("--overwrite", action="store_true",
                    help="--run-dir holds an earlier run: delete that run's files (only those `vtrack train` writes) "
                    "once the settings are checked, then train")
    tr.add_argument("--num-envs", type=opt.int_in(1, 4096), default=None,
                    help="parallel cars (default: from the hyperparameters)")
    tr.add_argument("--eval-freq", type=opt.int_in(0, 10**10), default=100_000,
                    help="evaluate every N steps, 0 = never (default: %(default)s)")
    tr.add_argument("--case1-max-steps", type=opt.int_in(1, 10**6), default=3000,
                    help="cap of the periodic LateralTracking-v0 evaluation (full lap every --case1-full-every)")
    tr.add_argument("--case1-full-every", type=opt.int_in(0, 10**6), default=5,
                    help="full-lap evaluation period, 0 = only at the end (default: 5)")
    opt.add_control(tr, "recorded in the run's hyperparameters (env_kwargs) and the agent file's observation names")
    tr.add_argument("--no-progress", action="store_true", help="no progress bar")
    tr.add_argument("--no-final-eval", action="store_true", help="skip the full evaluation at the end")
    tr.add_argument("--bc-expert", default=None, metavar="POLICY[:PRESET]",
                    help="ppo/sac: start from a behaviour-cloned actor of this scripted baseline (e.g. lqr or "
                    "mpc:hand), driven on the training env; RL then fine-tunes it (default: none, from scratch)")
    tr.add_argument("--bc-steps", type=opt.int_in(1, 10**6), default=None,
                    help="vector-env steps of expert data for --bc-expert (x num-envs transitions; default: 3000)")
    tr.add_argument("--bc-dagger-rounds", type=opt.int_in(0, 100), default=None,
                    help="DAgger rounds after the expert's own round, each --bc-steps long (default: 2)")
    tr.add_argument("--dagger-rounds", type=opt.int_in(0, 100), default=None,
                    help="--algo dagger: rounds driven by the clone after the expert's (default: the recipe's)")
    tr.add_argument("--dagger-circuits", type=opt.int_in(1, 1000), default=None,
                    help="--algo dagger on vtrack/Race-v0: training races per round (default: the recipe's)")
    tr.add_argument("--init-from", default=None, metavar="AGENT",
                    help="--algo sac --env vtrack/Race-v0: start from this race agent (a shipped name, e.g. "
                    "dagger_race_v2, or an agent file) and fine-tune it on the race reward over the race split's "
                    "training circuits (agents.race_finetune; --set takes its RaceFinetuneConfig fields)")
    tr.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", dest="hyperparams",
                    help="replace one hyperparameter of the YAML file, VALUE read as YAML (e.g. learning_rate=3e-5, "
                    "'policy_kwargs={net_arch: [64, 64]}', bc_weight=null to drop an entry); repeatable")


def needed_modules(args: argparse.Namespace) -> list[str]:
    return ["stable_baselines3", "torch", "yaml"]


def check_outputs(args: argparse.Namespace) -> None:
    from vtrack_gym.agents.train import RUN_FILES, check_run_dir

    check_output_dir(args.run_dir, "--run-dir")
    for name in RUN_FILES:  # each must be absent or a regular file
        check_output_file(args.run_dir / name, "--run-dir")
    check_run_dir(args.run_dir, args.overwrite)  # refused before any work; removed by train() with --overwrite


_EXPONENT_FLOAT = re.compile(r"[-+]?(\d+\.?\d*|\.\d+)[eE][-+]?\d+")


MAX_SET_CHARS = 4096
"""Longest ``--set`` VALUE [characters]."""


def check_set_value(key: str, value: object, depth: int = 0) -> None:
    """``ValueError`` naming ``--set KEY`` for nesting deeper than 8, integers beyond +-2^63 or non-finite numbers."""
    import math

    if depth > 8:
        raise ValueError(f"--set {key}: VALUE is nested deeper than 8 levels")
    if isinstance(value, bool) or value is None or isinstance(value, str):
        return
    if isinstance(value, int) and not -2**63 <= value < 2**63:
        raise ValueError(f"--set {key}: integer out of the range [-2^63, 2^63 - 1]")
    if isinstance(value, float) and not math.isfinite(value):
        raise ValueError(f"--set {key}: {value} is not a finite number")
    if isinstance(value, dict):
        for k, v in value.items():
            check_set_value(key, k, depth + 1)
            check_set_value(key, v, depth + 1)
    elif isinstance(value, (list, tuple)):
        for v in value:
            check_set_value(key, v, depth + 1)


def parse_hyperparams(items: Sequence[str]) -> dict[str, object]:
    """``--set KEY=VALUE`` items as a dict, each VALUE read with ``yaml.safe_load`` (never evaluated)."""
    import yaml

    values: dict[str, object] = {}
    for item in items:
        key, sep, text = item.partition("=")
        if not sep or not key.strip().isidentifier():
            raise ValueError(f"--set expects KEY=VALUE with KEY a hyperparameter name (got {item!r})")
        if len(text) > MAX_SET_CHARS:
            raise ValueError(f"--set {key.strip()}: VALUE is longer than {MAX_SET_CHARS} characters")
        try:
            value = yaml.safe_load(text)
        except (yaml.YAMLError, RecursionError, ValueError) as exc:
            raise ValueError(f"--set {key.strip()}: VALUE is not valid YAML ({text[:80]!r}): {exc}"[:400]) from None
        check_set_value(key.strip(), value)
        if isinstance(value, str) and _EXPONENT_FLOAT.fullmatch(value.strip()):
            value = float(value)  # YAML 1.1 reads 3e-5 (no dot) as a string
        values[key.strip()] = value
    return values


def run(args: argparse.Namespace) -> int:
    import json
    import shlex

    from vtrack_gym.agents.train import train

    command = shlex.join(["vtrack", *sys.argv[1:]]) if args.argv is None else shlex.join(["vtrack", *args.argv])
    if args.algo == "dagger":
        return _run_dagger(args, command)
    if args.init_from is not None:
        return _run_race_finetune(args, command)
    if args.dagger_rounds is not None or args.dagger_circuits is not None:
        raise ValueError("--dagger-rounds and --dagger-circuits apply to --algo dagger only")
    bc = None
    if args.bc_expert is None and (args.bc_steps is not None or args.bc_dagger_rounds is not None):
        raise ValueError("--bc-steps and --bc-dagger-rounds apply to a --bc-expert warm start only")
    if args.bc_expert is not None:
        from vtrack_gym.agents.imitation import BCConfig
        from vtrack_gym.baselines.registry import available_policies

        name, _, preset = args.bc_expert.partition(":")
        if name not in available_policies():
            raise ValueError(f"--bc-expert must be one of {', '.join(available_policies())}, optionally with "
                             f":PRESET (got {args.bc_expert!r})")
        defaults = BCConfig()
        bc = BCConfig(expert=name, expert_preset=preset or "default",
                      steps=defaults.steps if args.bc_steps is None else args.bc_steps,
                      dagger_rounds=defaults.dagger_rounds if args.bc_dagger_rounds is None else args.bc_dagger_rounds)
    summary = train(args.algo, args.env, args.timesteps, args.seed, str(args.run_dir), num_envs=args.num_envs,
                    overrides=parse_hyperparams(args.hyperparams),
                    eval_freq=args.eval_freq, case1_max_steps=args.case1_max_steps,
                    case1_full_every=args.case1_full_every, progress_bar=not args.no_progress, command=command,
                    final_eval=not args.no_final_eval, bc=bc, overwrite=args.overwrite, control=args.control)
    out(json.dumps({k: v for k, v in summary.items() if k not in ("model", "vecnormalize")}, indent=2,
                   default=str))
    if summary.get("interrupted"):
        err(f"vtrack train: interrupted at {summary['timesteps']} timesteps; the model as it was is saved in "
            f"{args.run_dir}/model.zip and exported to {summary['agent']} (config.json: interrupted: true). "
            f"`vtrack eval --policy {summary['agent']}` evaluates it, `vtrack export --run-dir {args.run_dir}` "
            "re-exports it")
        return 130
    return 0


def _run_dagger(args: argparse.Namespace, command: str) -> int:
    """``--algo dagger``: the recipe of ``agents.dagger.dagger_recipe`` for ``--env`` with the options given."""
    import json

    from vtrack_gym.agents.dagger import dagger_recipe

    refused = [flag for flag, value in (("--timesteps", args.timesteps), ("--set", args.hyperparams or None),
                                        ("--bc-dagger-rounds", args.bc_dagger_rounds)) if value is not None]
    if refused:
        raise ValueError(f"{', '.join(refused)} do not apply to --algo dagger (use --dagger-rounds, --bc-steps, "
                         "--num-envs, --dagger-circuits)")
    name, _, preset = (args.bc_expert or "").partition(":")
    summary = dagger_recipe(args.env, expert=name or None, expert_preset=preset or None, rounds=args.dagger_rounds,
                            steps=args.bc_steps, num_envs=args.num_envs, circuits_per_round=args.dagger_circuits,
                            control=args.control, seed=args.seed, run_dir=args.run_dir, command=command,
                            overwrite=args.overwrite)
    out(json.dumps(summary, indent=2, default=str))
    return 0


def _run_race_finetune(args: argparse.Namespace, command: str) -> int:
    """``--init-from``: ``agents.race_finetune.finetune_race`` of that agent (SAC on ``vtrack/Race-v0`` only)."""
    import dataclasses
    import json

    from vtrack_gym.agents.race_finetune import RaceFinetuneConfig, finetune_race

    if args.algo != "sac" or args.env != "vtrack/Race-v0":
        raise ValueError("--init-from applies to --algo sac --env vtrack/Race-v0 (the race fine-tune) only")
    refused = [flag for flag, value in (("--bc-expert", args.bc_expert), ("--num-envs", args.num_envs),
                                        ("--control", args.control)) if value is not None]
    if refused:
        raise ValueError(f"{', '.join(refused)} do not apply to --init-from")
    fields = {f.name for f in dataclasses.fields(RaceFinetuneConfig)}
    values = parse_hyperparams(args.hyperparams)
    unknown = sorted(set(values) - fields)
    if unknown:
        raise ValueError(f"--set {unknown[0]}: not a race fine-tune setting (valid: {', '.join(sorted(fields))})")
    if args.timesteps is not None:
        values["timesteps"] = args.timesteps
    if "critic_sizes" in values and isinstance(values["critic_sizes"], list):
        values["critic_sizes"] = tuple(values["critic_sizes"])
    summary = finetune_race(args.init_from, RaceFinetuneConfig(**values), seed=args.seed, run_dir=args.run_dir,
                            command=command, overwrite=args.overwrite)
    out(json.dumps(summary, indent=2, default=str))
    return 0
