"""``vtrack dataset``: a Minari dataset of a policy's episodes on a suite or an env (extra 'dataset')."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from vtrack_gym._io import check_output_dir
from vtrack_gym.cli import _options as opt
from vtrack_gym.cli._envs import check_vehicle
from vtrack_gym.cli._terminal import err, out

NAME = "dataset"


def register(sub: Any) -> None:
    from vtrack_gym.evaluation.benchmarking.dataset import MAX_EPISODES, dataset_suites

    ds = sub.add_parser(NAME, help="write a Minari dataset of a policy's episodes (extra 'dataset')",
                        description="Drive a policy deterministically through a suite's scenarios or one env and "
                        "write one Minari dataset per env id, locally (nothing is downloaded): observations, "
                        "actions, rewards, flags, the numeric infos, each episode's seed and reset options, and the "
                        "env's spec, so "
                        "minari.load_dataset(ID).recover_environment() makes the same env.")
    ds.add_argument("--policy", required=True,
                    help=opt.policy_help())
    opt.add_user_code(ds)
    where = ds.add_mutually_exclusive_group(required=True)
    where.add_argument("--suite", choices=dataset_suites(),
                       help="every scenario of the suite, its perturbations drawn from each seed")
    where.add_argument("--env", default=None, help="one registered env id, e.g. DLC120-v0")
    ds.add_argument("--episodes", type=opt.int_in(1, MAX_EPISODES), default=1,
                    help="episodes per env, seeds --seed, --seed + 1, ...; each starts from its seed's draw of "
                    "offset and heading error, so the episodes differ (default: 1)")
    ds.add_argument("--seed", "--episode-seed", dest="seed", type=opt.int_in(0, opt.MAX_RNG_SEED), default=0,
                    help="episode seed of the first episode (the env's reset seed; the others follow: --seed + 1, "
                    "...) (default: 0)")
    ds.add_argument("--name", default=None,
                    help="dataset name; ids are vtrack/<env>/<name>-v0 (default: <policy>-<suite or env>)")
    ds.add_argument("--root", type=Path, default=None,
                    help="datasets folder (default: Minari's own, $MINARI_DATASETS_PATH or ~/.minari/datasets)")
    opt.add_vehicle(ds)
    ds.add_argument("--no-progress", action="store_true", help="no progress bar")


def needed_modules(args: argparse.Namespace) -> list[str]:
    return ["minari", "h5py"]


def check_outputs(args: argparse.Namespace) -> None:
    if args.root is not None:
        check_output_dir(args.root, "--root")


def run(args: argparse.Namespace) -> int:
    from vtrack_gym.cli._policies import parse_policy_kwargs, policy_factory
    from vtrack_gym.evaluation.benchmarking.dataset import write_dataset

    check_vehicle(args)
    kwargs = parse_policy_kwargs(args.policy_kwargs)
    policy_factory(args.policy, trust_code=args.trust_code, kwargs=kwargs)  # checked before any episode
    ids = write_dataset(args.policy, suite=args.suite, env=args.env, episodes=args.episodes, seed=args.seed,
                        name=args.name, root=args.root, vehicle=args.vehicle, progress=not args.no_progress,
                        trust_code=args.trust_code, policy_kwargs=kwargs or None)
    for dataset_id in ids:
        out(dataset_id)
    where = f"MINARI_DATASETS_PATH={args.root} " if args.root is not None else ""
    err(f"vtrack dataset: wrote {len(ids)} Minari dataset(s); load one with {where}python -c \"import minari, "
        f"vtrack_gym; d = minari.load_dataset('{ids[0]}')\"")
    return 0
