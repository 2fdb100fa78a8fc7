"""The ``vtrack`` command (the only place that parses argv).

    vtrack benchmark            every baseline (and shipped agent) on the paper suite -> leaderboard + figures
    vtrack eval --policy mpc --env DLC120-v0
    vtrack leaderboard --suite paper --format md
    vtrack plot --policies smc,mpc --env LateralTracking-v0
    vtrack tune --controller smc --budget paper --space working --out smc_tuned.json
    vtrack video --policy mpc --env DLC120-v0 --out dlc.mp4
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
                        description="Print the leaderboard of a suite from the store (mean over episodes).")
    lb.add_argument("--suite", default="paper", help="suite to show: paper, robust or custom (default: paper)")
    _add_store(lb)
    _add_format(lb)

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

    vd = sub.add_parser("video", help="write an MP4 or GIF of policies driving a scenario (extra 'render')",
                        description="Drive one or more policies on one env (same seed) and write a top-down video: "
                        "MP4 through imageio-ffmpeg or GIF through Pillow, at real time or --speedup. Several "
                        "policies are shown side by side (one panel each) or overlaid in one frame.")
    vd.add_argument("--policy", default=None, help="one policy name or agent file (as for `vtrack eval`)")
    vd.add_argument("--policies", default=None, help="comma-separated policy names, e.g. mpc,smc")
    vd.add_argument("--env", required=True, help="env id, e.g. DLC120-v0 or LateralTracking-v0")
    vd.add_argument("--out", type=Path, required=True, help="output file ending in .mp4 or .gif")
    vd.add_argument("--preset", default="default", help="baseline preset for every policy (default: default)")
    vd.add_argument("--seed", type=int, default=0, help="episode seed (default: 0)")
    vd.add_argument("--speedup", type=float, default=1.0,
                    help="seconds of driving per second of video, in [0.05, 100] (default: 1 = real time)")
    vd.add_argument("--fps", type=int, default=25, help="frames per second of video, 1-120 (default: 25)")
    vd.add_argument("--seconds", type=float, default=None, help="stop after this much driving [s] (default: "
                    "the whole episode)")
    vd.add_argument("--arrangement", choices=("side", "overlay"), default="side",
                    help="several policies: side by side or overlaid in one frame (default: side)")
    vd.add_argument("--view", choices=("follow", "track"), default="follow",
                    help="follow: camera on the (first) car; track: the whole track (default: follow)")
    vd.add_argument("--view-width", type=float, default=60.0, help="follow view: metres across (default: 60)")
    vd.add_argument("--width", type=int, default=640, help="panel width in pixels, even (default: 640)")
    vd.add_argument("--height", type=int, default=384, help="panel height in pixels, even (default: 384)")

    r = sub.add_parser("reproduce", help="rerun the paper's Case 1 and Case 2 and check its claims",
                       description="Run PD-FLC + SMC and PD-FLC + MPC (paper presets and tuned/default presets) on "
                       "LateralTracking-v0 and DLC120-v0, write the paper-figure analogues to OUT/reproduction/ "
                       "and the claim-by-claim report OUT/REPRODUCTION.md (deterministic apart from a timestamp).")
    r.add_argument("--quick", action="store_true", help="cut every episode short (smoke test, not a reproduction)")
    r.add_argument("--out", type=Path, default=Path("docs"), help="output folder (default: docs)")
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
    rows, _ = score_policy(args.policy, make, [Episode(env_id, s) for s in seeds], "custom")
    ResultStore(args.store).add(rows)
    table = [{"seed": r.seed, "termination": r.termination, **{k: v for k, v in r.metrics.items()
                                                                 if isinstance(v, float)}} for r in rows]
    print(to_markdown(table))
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
    _print_board(ResultStore(args.store).leaderboard(args.suite, LEADERBOARD_COLUMNS), args.format)
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


def _cmd_video(args: argparse.Namespace) -> int:
    from vtrack_gym.envs.render import RenderConfig
    from vtrack_gym.evaluation.video import VideoConfig, check_video_path, record_video
    from vtrack_gym.interop import resolve_env_id

    if (args.policy is None) == (args.policies is None):
        raise ValueError("give exactly one of --policy NAME or --policies A,B")
    out = check_video_path(args.out)
    if args.seed < 0:
        raise ValueError(f"--seed must be >= 0 (got {args.seed})")
    render = RenderConfig(width_px=args.width, height_px=args.height, view=args.view, view_width_m=args.view_width,
                          fps=args.fps)
    config = VideoConfig(fps=args.fps, speedup=args.speedup, arrangement=args.arrangement, max_seconds=args.seconds,
                         render=render)
    import vtrack_gym

    env_id = _known_env(resolve_env_id(args.env))
    if env_id not in vtrack_gym.ENV_IDS:
        raise ValueError(f"vtrack video draws the vtrack envs only: {', '.join(vtrack_gym.ENV_IDS)} (got --env "
                         f"{args.env!r})")
    names = [args.policy] if args.policy is not None else [p.strip() for p in args.policies.split(",") if p.strip()]
    if not names:
        raise ValueError("--policies needs at least one policy name, e.g. --policies mpc,smc")
    policies = [(Path(n).stem if Path(n).suffix else n, _policy_factory(n, args.preset)) for n in names]
    result = record_video(env_id, policies, out, config, seed=args.seed,
                          progress=lambda msg: print(f"recording: {msg}", file=sys.stderr))
    print(f"video: {result['path']} ({result['frames']} frames, {result['video_s']:.1f} s of video for "
          f"{result['driven_s']:.1f} s of driving, written in {result['wall_s']:.1f} s)")
    return 0


def _cmd_tune(args: argparse.Namespace) -> int:
    import dataclasses
    import json
    import shlex

    from vtrack_gym.baselines.preset_files import save_preset
    from vtrack_gym.tuning.ga import tune
    from vtrack_gym.tuning.population import FitnessConfig
    from vtrack_gym.tuning.spaces import budget, search_space

    space = search_space(args.controller, args.space)
    b = budget(args.controller, args.budget)
    if args.generations is not None or args.pop_size is not None:
        b = dataclasses.replace(b, name="custom", generations=args.generations or b.generations,
                                pop_size=args.pop_size or b.pop_size)
    if args.backend != "ray" and (args.ray_address is not None or args.workers is not None):
        raise ValueError("--ray-address and --workers need --backend ray")
    if args.workers is not None and args.workers < 1:
        raise ValueError(f"--workers must be >= 1 (got {args.workers})")
    fitness = FitnessConfig(comfort_weight=args.comfort_weight)
    result = tune(space, b, seed=args.seed, fitness=fitness, progress=not args.no_progress, max_steps=args.max_steps,
                  also_complete=tuple(e for e in args.also_complete.split(",") if e), backend=args.backend,
                  ray_address=args.ray_address, num_workers=args.workers)
    out = args.out or Path("vtrack_results") / f"{args.controller}_tuned.json"
    command = "vtrack " + " ".join(shlex.quote(a) for a in (sys.argv[1:] if args.argv is None else args.argv))
    budget_info = {"name": b.name, "generations": b.generations, "pop_size": b.pop_size}
    provenance = {"command": command, "seed": args.seed, "budget": budget_info, "space": space.as_dict(),
                  "best_fitness": result.best_fitness, "metrics": result.best_metrics,
                  "scenario": ",".join(["LateralTracking-v0", *[e for e in args.also_complete.split(",") if e]]),
                  "wall_time_s": round(result.wall_s, 3),
                  "episodes": result.episodes, "backend": result.backend}
    if args.max_steps is not None:
        provenance["note"] = f"episodes cut after {args.max_steps} steps (smoke test, not a tuning result)"
    save_preset(out, args.controller, result.best_config, result.best_speed_config, provenance)
    eps = result.episodes / max(result.wall_s, 1e-9)
    print(json.dumps({"best_fitness": result.best_fitness, "initial_best_fitness": result.initial_best_fitness,
                      "params": result.params, **result.best_metrics}, indent=2))
    where = f" on {result.workers} Ray workers" if result.backend == "ray" else ""
    print(f"{result.episodes} episodes in {result.wall_s:.1f} s{where} ({eps:.2f} episodes/s); preset written to "
          f"{out}", file=sys.stderr)
    if args.store is not None:
        from vtrack_gym.evaluation.benchmark import policy_hash
        from vtrack_gym.evaluation.store import ResultRow, ResultStore

        class _Cfg:  # policy_hash reads .config
            config = result.best_config

        row = ResultRow(suite="tuning", env_id="LateralTracking-v0", policy_id=f"{args.controller}_tuned",
                        policy_hash=policy_hash(_Cfg()), seed=args.seed,
                        metrics={**result.best_metrics, "wall_time_s": result.wall_s,
                                 "episodes": float(result.episodes)},
                        termination="completed" if result.best_metrics.get("completed") else "not_completed",
                        wall_time_per_step_s=result.wall_s / max(result.car_steps, 1),
                        options={"space": f"{args.controller}/{args.space}", "budget": budget_info,
                                 "preset_file": str(out)})
        ResultStore(args.store).add([row])
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
                "train": _cmd_train, "export": _cmd_export, "video": _cmd_video,
                "tune": _cmd_tune, "reproduce": _cmd_reproduce}
    try:
        return handlers[args.command](args)
    except (ValueError, FileNotFoundError, ImportError, StoreError, sqlite3.Error, BackendError) as exc:
        print(f"vtrack {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
