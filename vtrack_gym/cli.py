"""The ``vtrack`` command (the only place that parses argv).

    vtrack benchmark            every baseline (and shipped agent) on the paper suite -> leaderboard + figures
    vtrack eval --policy mpc --env DLC120-v0
    vtrack leaderboard --suite paper --format md
    vtrack plot --policies smc,mpc --env LateralTracking-v0
    vtrack tune --controller smc --budget paper --space working --out smc_tuned.json
"""

from __future__ import annotations

import argparse
import logging
import re
import sqlite3
import sys
from collections.abc import Sequence
from pathlib import Path

from vtrack_gym.evaluation.store import DEFAULT_STORE_PATH, StoreError
from vtrack_gym.tuning.backends import BackendError

DEFAULT_FIGURES_DIR = Path("vtrack_results") / "figures"


def _add_store(p: argparse.ArgumentParser) -> None:
    p.add_argument("--store", type=Path, default=DEFAULT_STORE_PATH,
                   help=f"SQLite leaderboard file (created if missing; default: {DEFAULT_STORE_PATH})")


def _add_format(p: argparse.ArgumentParser, choices: Sequence[str] = ("md", "csv", "json")) -> None:
    names = {"md": "Markdown table", "csv": "CSV", "json": "JSON", "latex": "LaTeX booktabs tabular",
             "html": "self-contained HTML report (sortable table, figures embedded, no network)"}
    p.add_argument("--format", choices=choices, default="md",
                   help="how to print the leaderboard: " + ", ".join(f"{c} ({names[c]})" for c in choices)
                   + " (default: md)")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``vtrack`` (every option explained in --help)."""
    parser = argparse.ArgumentParser(prog="vtrack", description="Benchmark steering controllers and RL agents on "
                                     "the paper's trajectory-tracking scenarios.")
    parser.add_argument("-v", "--verbose", action="store_true", help="log progress details")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    b = sub.add_parser("benchmark", help="score every baseline and shipped agent on a suite; print the leaderboard",
                       description="Run every baseline policy (default presets) and every shipped RL agent on the "
                       "suite's episodes, store the results, print the leaderboard and write the figures.")
    b.add_argument("--suite", choices=("paper", "robust", "highway"), default="paper",
                   help="paper: the two nominal scenarios; robust: randomised friction, mass, speed, noise and "
                   "delay over fixed seeds; highway: highway-env's lane-keeping-v0 (needs the 'highway' extra) "
                   "(default: paper)")
    b.add_argument("--policies", default="",
                   help="comma-separated policy names to score (default: all; see `vtrack eval --help`)")
    b.add_argument("--figures", type=Path, default=DEFAULT_FIGURES_DIR,
                   help=f"folder for the PNG figures (default: {DEFAULT_FIGURES_DIR})")
    b.add_argument("--no-figures", action="store_true", help="skip the figures")
    b.add_argument("--quick", action="store_true", help="robust/highway suites: one seed only")
    _add_store(b)
    _add_format(b)

    e = sub.add_parser("eval", help="score one policy on one env", description="Run one policy on one env for one "
                       "or more seeds, print its metrics and add them to the store (suite 'custom').")
    e.add_argument("--policy", required=True,
                   help="a baseline name (smc, mpc, lqr, stanley, pure_pursuit, mpc_osqp), a shipped agent "
                   "name, or a weights-only agent file (agent.json / agent.npz)")
    e.add_argument("--env", required=True,
                   help="env id, e.g. LateralTracking-v0, DLC120-v0 or highway-env:lane-keeping-v0")
    e.add_argument("--preset", default="default",
                   help="baseline preset: default (for smc and mpc the shipped GA-tuned preset), tuned, hand "
                        "(hand-tuned smc/mpc) or paper (Table 3) (default: default)")
    e.add_argument("--seeds", default="0", help="comma-separated seeds (default: 0)")
    _add_store(e)

    lb = sub.add_parser("leaderboard", help="print the stored leaderboard",
                        description="Print the leaderboard of a suite from the store: one row per policy key (name, "
                        "preset, config or weights hash) and env, the mean over episodes (a metric missing in any "
                        "episode is shown as a dash). Opens the store read-only: it never creates or changes a file.")
    lb.add_argument("--suite", default="paper", help="suite to show: paper, robust or custom (default: paper)")
    lb.add_argument("--store", type=Path, default=DEFAULT_STORE_PATH,
                    help=f"SQLite leaderboard file, opened read-only (default: {DEFAULT_STORE_PATH})")
    _add_format(lb, ("md", "csv", "json", "latex", "html"))
    lb.add_argument("--out", type=Path, default=None, help="write the leaderboard to this file (default: stdout)")
    lb.add_argument("--figures", type=Path, default=DEFAULT_FIGURES_DIR,
                    help=f"--format html: embed the PNG figures of this folder if it exists (default: "
                    f"{DEFAULT_FIGURES_DIR})")
    lb.add_argument("--all-versions", action="store_true",
                    help="aggregate every stored row (default: only rows of the newest package version in the "
                    "suite, the newest row per policy key, env, seed and options)")

    tr = sub.add_parser("train", help="train an RL steering agent with stable-baselines3 (extra 'rl')",
                        description="Train PPO/SAC/TD3 on the native vector env (procedural tracks by default) with "
                        "the versioned hyperparameters of vtrack_gym/agents/hyperparams, evaluate on both paper "
                        "scenarios periodically, and export a weights-only agent (agent.json + agent.npz) that "
                        "`vtrack eval` and the benchmark load without torch.")
    tr.add_argument("--algo", choices=("ppo", "sac", "td3"), required=True, help="SB3 algorithm")
    tr.add_argument("--env", default="LateralTrackingRandom-v0", help="training env id (default: %(default)s)")
    tr.add_argument("--timesteps", type=int, default=1_000_000, help="environment steps (default: %(default)s)")
    tr.add_argument("--seed", type=int, default=0, help="training seed (default: 0)")
    tr.add_argument("--run-dir", type=Path, required=True, help="folder for config, logs, checkpoints and the agent")
    tr.add_argument("--num-envs", type=int, default=None, help="parallel cars (default: from the hyperparameters)")
    tr.add_argument("--eval-freq", type=int, default=100_000, help="evaluate every N steps (default: %(default)s)")
    tr.add_argument("--case1-max-steps", type=int, default=3000,
                    help="cap of the periodic LateralTracking-v0 evaluation (full lap every --case1-full-every)")
    tr.add_argument("--case1-full-every", type=int, default=5, help="full-lap evaluation period (default: 5)")
    tr.add_argument("--no-progress", action="store_true", help="no progress bar")
    tr.add_argument("--no-final-eval", action="store_true", help="skip the full evaluation at the end")
    tr.add_argument("--bc-expert", default=None, metavar="POLICY[:PRESET]",
                    help="ppo/sac: start from a behaviour-cloned actor of this scripted baseline (e.g. lqr or "
                    "mpc:hand), driven on the training env; RL then fine-tunes it (default: none, from scratch)")
    tr.add_argument("--bc-steps", type=int, default=None,
                    help="vector-env steps of expert data for --bc-expert (x num-envs transitions; default: 3000)")
    tr.add_argument("--bc-dagger-rounds", type=int, default=None,
                    help="DAgger rounds after the expert's own round, each --bc-steps long (default: 2)")
    tr.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", dest="hyperparams",
                    help="replace one hyperparameter of the YAML file, VALUE read as YAML (e.g. learning_rate=3e-5, "
                    "'policy_kwargs={net_arch: [64, 64]}', bc_weight=null to drop an entry); repeatable")

    ex = sub.add_parser("export", help="export a trained SB3 run to the weights-only agent format",
                        description="Load <run-dir>/model.zip and vecnormalize.pkl (your own training run: SB3 files "
                        "are pickles, load only files you trust) and write <out>.json + <out>.npz.")
    ex.add_argument("--run-dir", type=Path, required=True, help="folder written by `vtrack train`")
    ex.add_argument("--out", type=Path, required=True, help="output path without suffix, e.g. agents/ppo_dlc")

    pl = sub.add_parser("plot", help="write the paper's figures for some policies",
                        description="Roll out the given policies on one env and write trajectory, signal and "
                        "deviation-rate figures.")
    pl.add_argument("--policies", default="smc,mpc", help="comma-separated policy names (default: smc,mpc)")
    pl.add_argument("--env", default="LateralTracking-v0",
                    help="env id, also highway-env:lane-keeping-v0 (default: LateralTracking-v0)")
    pl.add_argument("--out", type=Path, default=DEFAULT_FIGURES_DIR, help="output folder")

    t = sub.add_parser("tune", help="GA-tune the SMC or MPC on Case 1 and write a tuned preset (JSON)",
                       description="Genetic algorithm (pymoo: rank selection, SBX 0.8, polynomial mutation 0.1) "
                       "minimising ITAE + constraint penalties on LateralTracking-v0. Each generation runs as one "
                       "batched rollout, in this process or (--backend ray) split over a Ray cluster's workers, with a "
                       "bit-identical result. Writes a JSON preset with provenance.")
    t.add_argument("--controller", choices=("smc", "mpc"), required=True, help="controller to tune")
    t.add_argument("--budget", choices=("paper", "quick"), default="paper",
                   help="paper: Table 2 (SMC 100 generations x 10, MPC 200 x 20); quick: 3 x 4 (default: paper)")
    t.add_argument("--space", choices=("paper", "working", "steering"), default="paper",
                   help="search space: paper (Table 2 bounds), working (SMC: p in [1, 15], eta in [1, 50], "
                   "Delta in [0.02, 1], the paper's G1..G4) or steering (SMC: the working p, eta, Delta with the "
                   "env's PD-FLC gains) (default: paper)")
    t.add_argument("--generations", type=int, default=None, help="override the budget's generations")
    t.add_argument("--pop-size", type=int, default=None, help="override the budget's population size")
    t.add_argument("--seed", type=int, default=0, help="GA seed (default: 0)")
    t.add_argument("--comfort-weight", type=float, default=0.0,
                   help="weight of the ISO 2631-1 comfort a_v in the fitness (default: 0 = off)")
    t.add_argument("--out", type=Path, default=None,
                   help="preset file to write (default: vtrack_results/<controller>_tuned.json)")
    t.add_argument("--store", type=Path, default=None,
                   help="also record the result in this leaderboard store (suite 'tuning'; default: none)")
    t.add_argument("--also-complete", default="",
                   help="comma-separated env ids every individual must also complete, e.g. DLC120-v0 (a failure "
                   "adds the incomplete-run penalty; default: none, the paper's Case-1-only fitness)")
    t.add_argument("--max-steps", type=int, default=None,
                   help="cut every episode after this many steps (smoke tests only; default: full episodes)")
    t.add_argument("--backend", choices=("local", "ray"), default="local",
                   help="where each generation is evaluated: local (one batched rollout in this process) or ray "
                   "(the population split over Ray workers; needs pip install \"vtrack_gym[ray]\"; same result) "
                   "(default: local)")
    t.add_argument("--ray-address", default=None, metavar="ADDR",
                   help="Ray cluster to connect to with --backend ray, e.g. 10.0.0.5:6379 (default: $RAY_ADDRESS "
                   "if set, else a local Ray instance started and stopped by this command)")
    t.add_argument("--workers", type=int, default=None, metavar="N",
                   help="Ray workers with --backend ray (default: the cluster's CPU count, at most the population "
                   "size)")
    t.add_argument("--no-progress", action="store_true", help="no progress bar")

    r = sub.add_parser("reproduce", help="rerun the paper's Case 1 and Case 2 and check its claims",
                       description="Run PD-FLC + SMC and PD-FLC + MPC (paper presets and tuned/default presets) on "
                       "LateralTracking-v0 and DLC120-v0, write the paper-figure analogues to OUT/reproduction/ "
                       "and the claim-by-claim report OUT/REPRODUCTION.md (deterministic apart from a timestamp).")
    r.add_argument("--quick", action="store_true", help="cut every episode short (smoke test, not a reproduction)")
    r.add_argument("--out", type=Path, default=Path("docs"), help="output folder (default: docs)")
    return parser


def _render_board(board: list[dict], fmt: str, title: str = "vtrack leaderboard",
                  figures: Sequence[Path] = ()) -> str:
    from vtrack_gym.evaluation import report_formats as rf

    if fmt == "html":
        from vtrack_gym.evaluation.html_report import to_html

        return to_html(board, title=title, figures=figures)
    return {"md": rf.to_markdown, "csv": rf.to_csv, "json": rf.to_json, "latex": rf.to_latex}[fmt](board).rstrip()


def _print_board(board: list[dict], fmt: str) -> None:
    print(_render_board(board, fmt))


def _cmd_benchmark(args: argparse.Namespace) -> int:
    from vtrack_gym.evaluation.benchmark import LEADERBOARD_COLUMNS, run_benchmark, summarise
    from vtrack_gym.evaluation.store import ResultStore

    store = ResultStore(args.store)  # verified before any rollout; written after the table is printed
    policies = [p for p in args.policies.split(",") if p] or None
    result = run_benchmark(args.suite, store=None, policies=policies,
                           figures_dir=None if args.no_figures else args.figures, quick=args.quick)
    _print_board(summarise(result["rows"], LEADERBOARD_COLUMNS), args.format)
    for f in result["figures"]:
        print(f"figure: {f}", file=sys.stderr)
    sys.stdout.flush()
    store.add(result["rows"])
    print(f"\nresults stored in {args.store}", file=sys.stderr)
    return 0


def _parse_seeds(text: str) -> list[int]:
    """Comma-separated non-negative integer seeds; ``ValueError`` naming the bad one."""
    seeds = []
    for item in (t.strip() for t in text.split(",")):
        if not item:
            continue
        if not item.isdigit():
            raise ValueError(f"--seeds must be comma-separated integers >= 0 (got {item!r})")
        seeds.append(int(item))
    if not seeds:
        raise ValueError("--seeds needs at least one seed, e.g. --seeds 0,1,2")
    return seeds


def _known_env(env_id: str) -> str:
    """``env_id`` if Gymnasium knows it (vtrack ids, the highway adapter), else a ValueError listing ours."""
    from gymnasium.envs.registration import registry

    import vtrack_gym

    if env_id not in registry:
        raise ValueError(f"unknown --env {env_id!r}; vtrack envs: {', '.join(vtrack_gym.ENV_IDS)}, "
                         "highway-env:lane-keeping-v0")
    return env_id


def _cmd_eval(args: argparse.Namespace) -> int:
    from vtrack_gym.evaluation.benchmark import score_policy
    from vtrack_gym.evaluation.store import ResultStore, to_markdown
    from vtrack_gym.evaluation.suites import Episode
    from vtrack_gym.interop import resolve_env_id

    seeds = _parse_seeds(args.seeds)
    make = _policy_factory(args.policy, args.preset)
    env_id = _known_env(resolve_env_id(args.env))
    store = ResultStore(args.store)  # verified before the rollouts; written after the table is printed
    rows, _ = score_policy(args.policy, make, [Episode(env_id, s) for s in seeds], "custom")
    table = [{"seed": r.seed, "termination": r.termination, **{k: v for k, v in r.metrics.items()
                                                                 if isinstance(v, float)}} for r in rows]
    print(to_markdown(table), flush=True)
    store.add(rows)
    return 0


def _policy_factory(name: str, preset: str):
    from vtrack_gym.evaluation.benchmark import policy_factories

    suffix = Path(name).suffix
    if suffix in (".json", ".npz"):
        from vtrack_gym.baselines.numpy_policy import load_agent  # json + np.load(allow_pickle=False): no code runs

        try:
            agent = load_agent(name)
        except (ValueError, OSError) as exc:
            raise ValueError(f"{name!r} looks like an agent file but is not a valid weights-only vtrack agent: "
                             f"{exc}") from None
        return lambda env: agent
    if suffix in (".zip", ".pkl") or Path(name).exists():
        raise ValueError(f"{name!r} looks like an agent file; only weights-only vtrack agents (agent.json + "
                         "agent.npz, written by `vtrack train` / `vtrack export`) are loaded: SB3 zips and "
                         "pickles can run code")
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
    store = ResultStore(args.store, read_only=True)
    board = store.leaderboard(args.suite, LEADERBOARD_COLUMNS, latest_only=not args.all_versions)
    figures = sorted(args.figures.glob("*.png")) if args.format == "html" and args.figures.is_dir() else []
    text = _render_board(board, args.format, title=f"vtrack leaderboard: suite {args.suite}", figures=figures)
    if args.out is None:
        print(text.rstrip())
        return 0
    try:
        args.out.write_text(text if text.endswith("\n") else text + "\n", encoding="utf-8")
    except OSError as exc:
        raise ValueError(f"cannot write --out {args.out}: {exc}") from None
    print(f"leaderboard written to {args.out}", file=sys.stderr)
    return 0


def _cmd_plot(args: argparse.Namespace) -> int:
    from vtrack_gym.evaluation.benchmark import score_policy, write_figures
    from vtrack_gym.evaluation.suites import Episode
    from vtrack_gym.interop import resolve_env_id

    env_id = _known_env(resolve_env_id(args.env))
    names = [p for p in args.policies.split(",") if p.strip()]
    if not names:
        raise ValueError("--policies needs at least one policy name, e.g. --policies smc,mpc")
    rows, traces = [], []
    for name in names:
        r, t = score_policy(name, _policy_factory(name, "default"), [Episode(env_id, 0)], "custom")
        rows += r
        traces += t
    for f in write_figures({env_id: traces}, rows, args.out):
        print(f"figure: {f}")
    return 0


def _cmd_tune(args: argparse.Namespace) -> int:
    import json
    import shlex

    from vtrack_gym.tuning.job import tune_to_preset

    if args.backend != "ray" and (args.ray_address is not None or args.workers is not None):
        raise ValueError("--ray-address and --workers need --backend ray")
    if args.workers is not None and args.workers < 1:
        raise ValueError(f"--workers must be >= 1 (got {args.workers})")
    command = "vtrack " + " ".join(shlex.quote(a) for a in (sys.argv[1:] if args.argv is None else args.argv))
    outcome = tune_to_preset(
        args.controller, args.space, args.budget, seed=args.seed, generations=args.generations,
        pop_size=args.pop_size, comfort_weight=args.comfort_weight, max_steps=args.max_steps,
        also_complete=tuple(e for e in args.also_complete.split(",") if e), backend=args.backend,
        ray_address=args.ray_address, num_workers=args.workers, out=args.out, store=args.store, command=command,
        progress=not args.no_progress)
    result = outcome.result
    print(json.dumps({"best_fitness": result.best_fitness, "initial_best_fitness": result.initial_best_fitness,
                      "params": result.params, **result.best_metrics}, indent=2))
    where = f" on {result.workers} Ray workers" if result.backend == "ray" else ""
    print(f"{result.episodes} episodes in {result.wall_s:.1f} s{where} ({outcome.episodes_per_s:.2f} episodes/s); "
          f"preset written to {outcome.preset_file}", file=sys.stderr)
    if args.store is not None:
        print(f"result stored in {args.store} (suite 'tuning')", file=sys.stderr)
    return 0


def _cmd_reproduce(args: argparse.Namespace) -> int:
    import time

    from vtrack_gym.evaluation.reproduce import reproduce

    start = time.perf_counter()
    result = reproduce(args.out, quick=args.quick, progress=lambda msg: print(f"running {msg}", file=sys.stderr))
    for f in result["figures"]:
        print(f"figure: {f}", file=sys.stderr)
    print(f"report: {result['report']} ({time.perf_counter() - start:.1f} s)")
    return 0


_EXPONENT_FLOAT = re.compile(r"[-+]?(\d+\.?\d*|\.\d+)[eE][-+]?\d+")


def _parse_hyperparams(items: Sequence[str]) -> dict[str, object]:
    """``--set KEY=VALUE`` items as a dict, each VALUE read with ``yaml.safe_load`` (never evaluated)."""
    import yaml

    out: dict[str, object] = {}
    for item in items:
        key, sep, text = item.partition("=")
        if not sep or not key.strip().isidentifier():
            raise ValueError(f"--set expects KEY=VALUE with KEY a hyperparameter name (got {item!r})")
        try:
            value = yaml.safe_load(text)
        except yaml.YAMLError as exc:
            raise ValueError(f"--set {key.strip()}: VALUE is not valid YAML ({text!r}): {exc}") from None
        if isinstance(value, str) and _EXPONENT_FLOAT.fullmatch(value.strip()):
            value = float(value)  # YAML 1.1 reads 3e-5 (no dot) as a string
        out[key.strip()] = value
    return out


def _cmd_train(args: argparse.Namespace) -> int:
    import json
    import shlex

    from vtrack_gym.agents.train import train

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
    command = shlex.join(["vtrack", *sys.argv[1:]]) if args.argv is None else shlex.join(["vtrack", *args.argv])
    summary = train(args.algo, args.env, args.timesteps, args.seed, str(args.run_dir), num_envs=args.num_envs,
                    overrides=_parse_hyperparams(args.hyperparams),
                    eval_freq=args.eval_freq, case1_max_steps=args.case1_max_steps,
                    case1_full_every=args.case1_full_every, progress_bar=not args.no_progress, command=command,
                    final_eval=not args.no_final_eval, bc=bc)
    print(json.dumps({k: v for k, v in summary.items() if k not in ("model", "vecnormalize")}, indent=2,
                     default=str))
    return 0


def _cmd_export(args: argparse.Namespace) -> int:
    import json

    from vtrack_gym.agents.export import export_run

    json_path, npz_path = export_run(args.run_dir, args.out)
    print(json.dumps({"json": str(json_path), "npz": str(npz_path)}))
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``vtrack``; returns the process exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    args.argv = None if argv is None else list(argv)
    logging.basicConfig(level=logging.INFO if args.verbose else logging.WARNING, format="%(levelname)s %(message)s")
    import vtrack_gym  # noqa: F401  (registers the env ids)

    handlers = {"benchmark": _cmd_benchmark, "eval": _cmd_eval, "leaderboard": _cmd_leaderboard, "plot": _cmd_plot,
                "train": _cmd_train, "export": _cmd_export,
                "tune": _cmd_tune, "reproduce": _cmd_reproduce}
    try:
        return handlers[args.command](args)
    except (ValueError, FileNotFoundError, ImportError, StoreError, sqlite3.Error, BackendError) as exc:
        print(f"vtrack {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
