"""``vtrack export``: a trained SB3 model as a weights-only agent file (no torch needed to run it)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from vtrack_gym._io import check_output_file
from vtrack_gym.cli import _options as opt
from vtrack_gym.cli._envs import known_env
from vtrack_gym.cli._terminal import err, out

NAME = "export"
DEFAULT_ENV = "LateralTrackingRandom-v0"
"""The env ``--model`` records when only ``--control-period-s`` is given."""


def register(sub: Any) -> None:
    ex = sub.add_parser(NAME, help="turn a trained SB3 model into a weights-only agent file",
                        description="Load <run-dir>/model.zip and vecnormalize.pkl, or --model M.zip (and "
                        "--vecnormalize V.pkl), and write <out>.json + <out>.npz (weights, observation normalisation "
                        "and the env's observation layout, control period and action scaling). SB3 files are "
                        "pickles: loading one runs any code it contains. A --run-dir written by `vtrack train` on "
                        "this machine (it holds a signature made with this user's key and the run's files) is "
                        "exported as is; any other run folder and every --model need --trust-code. Needs the 'rl' "
                        "extra.")
    src = ex.add_mutually_exclusive_group(required=True)
    src.add_argument("--run-dir", type=Path, help="folder written by `vtrack train` (its model.zip and "
                     "vecnormalize.pkl are unpickled: another machine's run folder needs --trust-code)")
    src.add_argument("--model", type=Path, help="an SB3 model file (model.zip) of a PPO/SAC/TD3 MlpPolicy; it is "
                     "unpickled, so it needs --trust-code")
    ex.add_argument("--trust-code", "--trust", dest="trust_code", action="store_true",
                    help="unpickle the SB3 files even though vtrack cannot vouch for them (a --model file, a run "
                    "folder copied from elsewhere or changed since training): only for files you trust")
    ex.add_argument("--algo", choices=("ppo", "sac", "td3"), default=None, help="algorithm of --model (required "
                    "with --model)")
    ex.add_argument("--vecnormalize", type=Path, default=None,
                    help="with --model: the VecNormalize statistics (vecnormalize.pkl) the model was trained with")
    ex.add_argument("--env", default=None,
                    help=f"with --model: the env whose contract the file records (default: {DEFAULT_ENV})")
    ex.add_argument("--control-period-s", type=opt.float_in(1e-3, 1.0), default=None,
                    help="with --model: the decision period [s] the model was trained at (e.g. 0.05 for the "
                    "TrainingMix-v0 recipes; default: the --env's own, said on stderr). A model file does not "
                    "record it: --model needs --env or --control-period-s")
    ex.add_argument("--raw-observations", action="store_true",
                    help="with --model and no --vecnormalize: the model was trained on raw observations (skips "
                    "the refusal when a vecnormalize.pkl lies next to it or its observation space looks scaled)")
    ex.add_argument("--out", type=Path, required=True, help="output path without suffix, e.g. agents/ppo_dlc")


def needed_modules(args: argparse.Namespace) -> list[str]:
    return ["stable_baselines3", "torch", "yaml"]


def check_outputs(args: argparse.Namespace) -> None:
    for suffix in (".json", ".npz"):
        check_output_file(args.out.parent / (args.out.name + suffix), "--out")


def run(args: argparse.Namespace) -> int:
    import json

    from vtrack_gym.agents.export import export_model, export_run

    if args.run_dir is not None:
        if args.algo or args.vecnormalize or args.control_period_s is not None or args.raw_observations:
            raise ValueError("--algo, --vecnormalize, --control-period-s and --raw-observations go with --model; "
                             "--run-dir reads them from the run")
        json_path, npz_path = export_run(args.run_dir, args.out, trust=args.trust_code)
    else:
        if args.algo is None:
            raise ValueError("--model needs --algo (ppo, sac or td3)")
        if not args.trust_code:
            raise ValueError(f"--model {args.model} is an SB3 pickle: loading it runs any code it contains. Pass "
                             "--trust-code if you produced it or trust its source (or export a `vtrack train` run "
                             "folder of this machine with --run-dir)")
        if args.env is None and args.control_period_s is None:
            raise ValueError(f"--model {args.model}: an SB3 model file does not record the decision period it was "
                             "trained at, and vtrack does not guess it: pass --control-period-s (e.g. 0.05 for the "
                             "TrainingMix-v0 recipes) or the training --env (its own period is recorded), or export "
                             "the `vtrack train` run folder with --run-dir")
        args.env = args.env or DEFAULT_ENV
        known_env(args.env)
        if args.vecnormalize is not None and args.raw_observations:
            raise ValueError("--raw-observations contradicts --vecnormalize: pass one of them")
        env_kwargs = None if args.control_period_s is None else {"control_period_s": args.control_period_s}
        json_path, npz_path = export_model(args.model, args.out, args.algo, args.vecnormalize, env_id=args.env,
                                           command="vtrack export --model " + str(args.model), env_kwargs=env_kwargs,
                                           raw_observations=args.raw_observations)
        spec = json.loads(json_path.read_text(encoding="utf-8"))
        if args.control_period_s is None and "env" in spec:
            err(f"vtrack export: note: decision period {spec['env']['control_period_s']:g} s, {args.env}'s own "
                  "(pass --control-period-s if the model was trained at another)")
        if args.vecnormalize is None:
            err("vtrack export: note: the agent takes raw observations (no --vecnormalize)")
    out(json.dumps({"json": str(json_path), "npz": str(npz_path)}))
    return 0
