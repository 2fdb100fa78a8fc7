"""The ``vtrack`` command (the only place that parses argv).

    vtrack benchmark            every baseline (and shipped agent) on the paper suite -> leaderboard + figures
    vtrack eval --policy mpc --env DLC120-v0
    vtrack leaderboard --suite paper --format md
    vtrack plot --policies smc,mpc --env LateralTracking-v0
"""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Sequence
from pathlib import Path

from vtrack_gym.evaluation.store import DEFAULT_STORE_PATH

DEFAULT_FIGURES_DIR = Path("vtrack_results") / "figures"


def _add_store(p: argparse.ArgumentParser) -> None:
    p.add_argument("--store", type=Path, default=DEFAULT_STORE_PATH,
                   help=f"SQLite leaderboard file (created if missing; default: {DEFAULT_STORE_PATH})")


def _add_format(p: argparse.ArgumentParser) -> None:
    p.add_argument("--format", choices=("md", "csv", "json"), default="md",
                   help="how to print the leaderboard: Markdown table, CSV or JSON (default: md)")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``vtrack`` (every option explained in --help)."""
    parser = argparse.ArgumentParser(prog="vtrack", description="Benchmark steering controllers and RL agents on "
                                     "the paper's trajectory-tracking scenarios.")
    parser.add_argument("-v", "--verbose", action="store_true", help="log progress details")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    b = sub.add_parser("benchmark", help="score every baseline and shipped agent on a suite; print the leaderboard",
                       description="Run every baseline policy (default presets) and every shipped RL agent on the "
                       "suite's episodes, store the results, print the leaderboard and write the figures.")
    b.add_argument("--suite", choices=("paper", "robust"), default="paper",
                   help="paper: the two nominal scenarios; robust: randomised friction, mass, speed, noise and "
                   "delay over fixed seeds (default: paper)")
    b.add_argument("--policies", default="",
                   help="comma-separated policy names to score (default: all; see `vtrack eval --help`)")
    b.add_argument("--figures", type=Path, default=DEFAULT_FIGURES_DIR,
                   help=f"folder for the PNG figures (default: {DEFAULT_FIGURES_DIR})")
    b.add_argument("--no-figures", action="store_true", help="skip the figures")
    b.add_argument("--quick", action="store_true", help="robust suite: one seed instead of five")
    _add_store(b)
    _add_format(b)

    e = sub.add_parser("eval", help="score one policy on one env", description="Run one policy on one env for one "
                       "or more seeds, print its metrics and add them to the store (suite 'custom').")
    e.add_argument("--policy", required=True,
                   help="a baseline name: smc, mpc, lqr, stanley, pure_pursuit or mpc_osqp")
    e.add_argument("--env", required=True, help="env id, e.g. LateralTracking-v0 or DLC120-v0")
    e.add_argument("--preset", default="default", help="baseline preset: default, paper or tuned (default: default)")
    e.add_argument("--seeds", default="0", help="comma-separated seeds (default: 0)")
    _add_store(e)

    lb = sub.add_parser("leaderboard", help="print the stored leaderboard",
                        description="Print the leaderboard of a suite from the store (mean over episodes).")
    lb.add_argument("--suite", default="paper", help="suite to show: paper, robust or custom (default: paper)")
    _add_store(lb)
    _add_format(lb)

    pl = sub.add_parser("plot", help="write the paper's figures for some policies",
                        description="Roll out the given policies on one env and write trajectory, signal and "
                        "deviation-rate figures.")
    pl.add_argument("--policies", default="smc,mpc", help="comma-separated policy names (default: smc,mpc)")
    pl.add_argument("--env", default="LateralTracking-v0", help="env id (default: LateralTracking-v0)")
    pl.add_argument("--out", type=Path, default=DEFAULT_FIGURES_DIR, help="output folder")
    return parser


def _print_board(board: list[dict], fmt: str) -> None:
    from vtrack_gym.evaluation.store import to_csv, to_json, to_markdown

    print({"md": to_markdown, "csv": to_csv, "json": to_json}[fmt](board).rstrip())


def _cmd_benchmark(args: argparse.Namespace) -> int:
    from vtrack_gym.evaluation.benchmark import LEADERBOARD_COLUMNS, run_benchmark, summarise
    from vtrack_gym.evaluation.store import ResultStore

    store = ResultStore(args.store)
    policies = [p for p in args.policies.split(",") if p] or None
    result = run_benchmark(args.suite, store=store, policies=policies,
                           figures_dir=None if args.no_figures else args.figures, quick=args.quick)
    _print_board(summarise(result["rows"], LEADERBOARD_COLUMNS), args.format)
    print(f"\nresults stored in {args.store}", file=sys.stderr)
    for f in result["figures"]:
        print(f"figure: {f}", file=sys.stderr)
    return 0


def _cmd_eval(args: argparse.Namespace) -> int:
    from vtrack_gym.evaluation.benchmark import score_policy
    from vtrack_gym.evaluation.store import ResultStore, to_markdown
    from vtrack_gym.evaluation.suites import Episode

    seeds = [int(s) for s in args.seeds.split(",") if s.strip()]
    make = _policy_factory(args.policy, args.preset)
    rows, _ = score_policy(args.policy, make, [Episode(args.env, s) for s in seeds], "custom")
    ResultStore(args.store).add(rows)
    table = [{"seed": r.seed, "termination": r.termination, **{k: v for k, v in r.metrics.items()
                                                                 if isinstance(v, float)}} for r in rows]
    print(to_markdown(table))
    return 0


def _policy_factory(name: str, preset: str):
    from vtrack_gym.evaluation.benchmark import policy_factories

    if Path(name).suffix in (".json", ".npz", ".zip", ".pkl") or Path(name).exists():
        raise ValueError(f"{name!r} looks like an agent file; this version evaluates baseline policies only "
                         "(weights-only agent files come with the shipped RL agents). Pass a baseline name.")
    if preset != "default":
        from vtrack_gym.baselines.registry import make_policy

        return lambda env: make_policy(name, env, preset=preset)
    factories = policy_factories()
    if name not in factories:
        raise ValueError(f"unknown policy {name!r}; valid: {', '.join(factories)} or an agent file path")
    return factories[name]


def _cmd_leaderboard(args: argparse.Namespace) -> int:
    from vtrack_gym.evaluation.benchmark import LEADERBOARD_COLUMNS
    from vtrack_gym.evaluation.store import ResultStore

    if not args.store.exists():
        print(f"no store at {args.store}: run `vtrack benchmark` first (or pass --store)", file=sys.stderr)
        return 2
    _print_board(ResultStore(args.store).leaderboard(args.suite, LEADERBOARD_COLUMNS), args.format)
    return 0


def _cmd_plot(args: argparse.Namespace) -> int:
    from vtrack_gym.evaluation.benchmark import score_policy, write_figures
    from vtrack_gym.evaluation.suites import Episode

    rows, traces = [], []
    for name in [p for p in args.policies.split(",") if p]:
        r, t = score_policy(name, _policy_factory(name, "default"), [Episode(args.env, 0)], "custom")
        rows += r
        traces += t
    for f in write_figures({args.env: traces}, rows, args.out):
        print(f"figure: {f}")
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``vtrack``; returns the process exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO if args.verbose else logging.WARNING, format="%(levelname)s %(message)s")
    import vtrack_gym  # noqa: F401  (registers the env ids)

    handlers = {"benchmark": _cmd_benchmark, "eval": _cmd_eval, "leaderboard": _cmd_leaderboard, "plot": _cmd_plot}
    try:
        return handlers[args.command](args)
    except (ValueError, FileNotFoundError) as exc:
        print(f"vtrack {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
