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
from typing import Any

from vtrack_gym._io import check_output_dir, check_output_file, check_regular_input, write_atomic
from vtrack_gym.evaluation.store import DEFAULT_STORE_PATH, MAX_SEED, StoreError
from vtrack_gym.tracks.path import MAX_V_REF_MPS, MIN_V_REF_MPS
from vtrack_gym.tracks.speed_profiles import MAX_ACCEL_MPS2
from vtrack_gym.tuning.backends import BackendError
from vtrack_gym.vehicle.params import GRAVITY_MPS2

DEFAULT_RESULTS_DIR = Path("vtrack_results")
DEFAULT_FIGURES_DIR = DEFAULT_RESULTS_DIR / "figures"
DEFAULT_PLOTS_DIR = DEFAULT_RESULTS_DIR / "plots"


MAX_SEEDS = 10_000
"""Most seeds one ``vtrack eval`` runs."""
MAX_FIGURE_BYTES = 32 * 2**20
"""Largest PNG ``leaderboard --format html`` embeds [bytes] (larger ones and non-regular files are skipped)."""
MAX_RNG_SEED = 2**32 - 1
"""Largest ``--seed`` of ``train`` and ``tune`` (numpy's legacy seeding, used by SB3 and pymoo, takes 32 bits)."""


_INTEGER = re.compile(r"[+-]?[0-9]+")


def _int_in(low: int, high: int):
    """An argparse ``type``: an integer in [low, high]; argparse names the option in its error."""
    def parse(text: str) -> int:
        t = text.strip()
        if len(t) > 30 or not _INTEGER.fullmatch(t):
            raise argparse.ArgumentTypeError(f"must be an integer in [{low}, {high}] (got {text[:40]!r})")
        value = int(t)
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"must be an integer in [{low}, {high}] (got {value})")
        return value
    parse.__name__ = "integer"
    return parse


def _float_in(low: float, high: float):
    """An argparse ``type``: a finite number in [low, high]."""
    def parse(text: str) -> float:
        try:
            value = float(text) if len(text) <= 40 and "_" not in text else float("nan")  # no "1_0"
        except ValueError:
            value = float("nan")
        if not low <= value <= high:  # also NaN and inf
            raise argparse.ArgumentTypeError(f"must be a number in [{low:g}, {high:g}] (got {text[:40]!r})")
        return value
    parse.__name__ = "number"
    return parse


def _add_store(p: argparse.ArgumentParser) -> None:
    p.add_argument("--store", type=Path, default=DEFAULT_STORE_PATH,
                   help=f"SQLite leaderboard file (created if missing; default: {DEFAULT_STORE_PATH})")


def _add_format(p: argparse.ArgumentParser, choices: Sequence[str] = ("md", "csv", "json")) -> None:
    names = {"md": "Markdown table", "csv": "CSV", "json": "JSON", "latex": "LaTeX booktabs tabular",
             "html": "self-contained HTML report (sortable table, figures embedded, no network)"}
    p.add_argument("--format", choices=choices, default="md",
                   help="how to print the leaderboard: " + ", ".join(f"{c} ({names[c]})" for c in choices)
                   + " (default: md)")


class _Parser(argparse.ArgumentParser):
    """``argparse.ArgumentParser`` that refuses ``--opt=--``: argparse drops the ``--`` and hands the option an
    empty list instead of a value (``vtrack tune --generations=--`` gave ``generations = []``)."""

    def _get_values(self, action: argparse.Action, arg_strings: list[str]) -> Any:
        if action.option_strings and action.nargs is None and arg_strings == ["--"]:
            self.error(f"argument {'/'.join(action.option_strings)}: expected one value, got '--'")
        return super()._get_values(action, arg_strings)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``vtrack`` (every option explained in --help)."""
    parser = _Parser(prog="vtrack", description="Benchmark steering controllers and RL agents on "
                                     "the paper's trajectory-tracking scenarios.")
    parser.add_argument("-v", "--verbose", action="store_true",
                        help="log details to stderr: every episode's result, the kernel cache (the long phases "
                        "are always announced)")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    b = sub.add_parser("benchmark", help="score every baseline and shipped agent on a suite; print the leaderboard",
                       description="Run every baseline policy (default presets) and every shipped RL agent on the "
                       "suite's episodes, store the results, print the leaderboard and write the figures.")
    b.add_argument("--suite", choices=("paper", "robust", "highway", "maneuvers"), default=None,
                   help="paper: the two nominal scenarios; robust: randomised friction, mass, speed, noise and "
                   "delay over fixed seeds; highway: highway-env's lane-keeping-v0 (needs the 'highway' extra); "
                   "maneuvers: the standard manoeuvres (ISO 3888-1/-2, ISO 4138 circle, slalom, step curvature), "
                   "one figure each (default: paper; not with --track)")
    b.add_argument("--policies", default="",
                   help="comma-separated policy names to score (default: all; see `vtrack eval --help`)")
    b.add_argument("--figures", type=Path, default=DEFAULT_FIGURES_DIR,
                   help=f"folder for the PNG figures (default: {DEFAULT_FIGURES_DIR})")
    b.add_argument("--no-figures", action="store_true", help="skip the figures")
    b.add_argument("--quick", action="store_true", help="robust/highway suites: one seed only (stored as suite "
                   "'robust[quick]' / 'highway[quick]', apart from the standard board)")
    b.add_argument("--seeds", default=None,
                   help="seeds to score, e.g. 0-9 or 0,3,5 (default: the suite's: paper 0, deterministic without "
                   "noise; robust five fixed seeds; highway 0-2); the table shows 95 %% bootstrap intervals; other "
                   "seeds are stored as suite NAME[seeds=...], apart from the standard board")
    _add_track(b, "score the policies on this CSV track file (suite 'custom', seed 0 or --seeds) instead of "
               "--suite (not with --suite or --quick)")
    _add_vehicle(b)
    _add_store(b)
    _add_format(b)

    e = sub.add_parser("eval", help="score one policy on one env", description="Run one policy on one env for one "
                       "or more seeds, print its metrics and add them to the store (suite 'custom').")
    e.add_argument("--policy", required=True,
                   help="a baseline name (smc, mpc, lqr, stanley, pure_pursuit, mpc_osqp), NAME:PRESET (smc:paper), "
                   "a shipped agent name (ppo, sac), a weights-only agent file (agent.json / agent.npz), or, with "
                   "--trust-code, MODULE:NAME of your own policy class (called as NAME(env) or NAME())")
    e.add_argument("--trust-code", action="store_true",
                   help="allow --policy MODULE:NAME: imports and runs that Python module (your code; the working "
                   "directory is on the import path)")
    where = e.add_mutually_exclusive_group(required=True)
    where.add_argument("--env", default=None,
                       help="env id, e.g. LateralTracking-v0, DLC120-v0 or highway-env:lane-keeping-v0")
    _add_track(e, where=where)
    e.add_argument("--preset", default="default",
                   help="baseline preset: default (for smc and mpc the shipped GA-tuned preset), tuned, hand "
                        "(hand-tuned smc/mpc) or paper (Table 3) (default: default)")
    e.add_argument("--seeds", default="0", help="seeds, e.g. 0-9 or 0,3,5 (default: 0)")
    _add_vehicle(e)
    _add_store(e)

    lb = sub.add_parser("leaderboard", help="print the stored leaderboard",
                        description="Print the leaderboard of a suite from the store: one row per policy key (name, "
                        "preset, config or weights hash) and env, ranked by success rate, then the suite's primary "
                        "metric over successful episodes (failed episodes are counted apart); means with 95 % "
                        "bootstrap intervals (a metric missing in any episode is shown as a dash). Opens the store "
                        "read-only: it never creates or changes a file.")
    lb.add_argument("--suite", default="paper",
                    help="suite to show: one present in the store, e.g. paper, robust, highway, custom (what "
                    "`vtrack eval` adds) or tuning; the command lists the store's suites (default: paper)")
    lb.add_argument("--store", type=Path, default=DEFAULT_STORE_PATH,
                    help=f"SQLite leaderboard file, opened read-only (default: {DEFAULT_STORE_PATH})")
    _add_format(lb, ("md", "csv", "json", "latex", "html"))
    lb.add_argument("--out", type=Path, default=None,
                    help="write the leaderboard to this file (default: stdout); never the store, its -wal/-shm/"
                    "-journal files or another SQLite file")
    lb.add_argument("--figures", type=Path, default=DEFAULT_FIGURES_DIR,
                    help=f"--format html: embed the PNG figures of this folder if it exists (default: "
                    f"{DEFAULT_FIGURES_DIR})")
    lb.add_argument("--all-versions", action="store_true",
                    help="aggregate every stored row (default: only rows of the newest package version in the "
                    "suite, the newest row per policy key, env, seed and options)")

    tr = sub.add_parser("train", help="train an RL steering agent with stable-baselines3 (extra 'rl')",
                        description="Train PPO/SAC/TD3 on the native vector env (the training mix by default) with "
                        "the versioned hyperparameters of vtrack_gym/agents/hyperparams, evaluate on both paper "
                        "scenarios periodically, and export a weights-only agent (agent.json + agent.npz) that "
                        "`vtrack eval` and the benchmark load without torch.")
    tr.add_argument("--algo", choices=("ppo", "sac", "td3"), required=True, help="SB3 algorithm")
    tr.add_argument("--env", default=None,
                    help="training env id (default: vtrack/TrainingMix20Hz-v0, the from-scratch recipes' training "
                    "mix at 20 Hz decisions; "
                    "with --bc-expert: LateralTrackingRandom-v0, the imitation recipes')")
    tr.add_argument("--timesteps", type=_int_in(1, 10**10), default=None,
                    help="environment steps (default: the hyperparameter entry's n_timesteps)")
    tr.add_argument("--seed", type=_int_in(0, MAX_RNG_SEED), default=0, help="training seed (default: 0)")
    tr.add_argument("--run-dir", type=Path, required=True, help="folder for config, logs, checkpoints and the agent "
                    "(a folder that already holds a run is refused, see --overwrite)")
    tr.add_argument("--overwrite", action="store_true",
                    help="--run-dir holds an earlier run: delete that run's files (only those `vtrack train` writes) "
                    "once the settings are checked, then train")
    tr.add_argument("--num-envs", type=_int_in(1, 4096), default=None,
                    help="parallel cars (default: from the hyperparameters)")
    tr.add_argument("--eval-freq", type=_int_in(0, 10**10), default=100_000,
                    help="evaluate every N steps, 0 = never (default: %(default)s)")
    tr.add_argument("--case1-max-steps", type=_int_in(1, 10**6), default=3000,
                    help="cap of the periodic LateralTracking-v0 evaluation (full lap every --case1-full-every)")
    tr.add_argument("--case1-full-every", type=_int_in(0, 10**6), default=5,
                    help="full-lap evaluation period, 0 = only at the end (default: 5)")
    tr.add_argument("--no-progress", action="store_true", help="no progress bar")
    tr.add_argument("--no-final-eval", action="store_true", help="skip the full evaluation at the end")
    tr.add_argument("--bc-expert", default=None, metavar="POLICY[:PRESET]",
                    help="ppo/sac: start from a behaviour-cloned actor of this scripted baseline (e.g. lqr or "
                    "mpc:hand), driven on the training env; RL then fine-tunes it (default: none, from scratch)")
    tr.add_argument("--bc-steps", type=_int_in(1, 10**6), default=None,
                    help="vector-env steps of expert data for --bc-expert (x num-envs transitions; default: 3000)")
    tr.add_argument("--bc-dagger-rounds", type=_int_in(0, 100), default=None,
                    help="DAgger rounds after the expert's own round, each --bc-steps long (default: 2)")
    tr.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", dest="hyperparams",
                    help="replace one hyperparameter of the YAML file, VALUE read as YAML (e.g. learning_rate=3e-5, "
                    "'policy_kwargs={net_arch: [64, 64]}', bc_weight=null to drop an entry); repeatable")

    ex = sub.add_parser("export", help="turn a trained SB3 model into a weights-only agent file",
                        description="Load <run-dir>/model.zip and vecnormalize.pkl, or --model M.zip (and "
                        "--vecnormalize V.pkl), and write <out>.json + <out>.npz (weights, observation normalisation "
                        "and the env's observation layout, control period and action scaling). SB3 files are "
                        "pickles: loading one runs any code it contains. A --run-dir written by `vtrack train` on "
                        "this machine (it holds a signature made with this user's key and the run's files) is "
                        "exported as is; any other run folder and every --model need --trust. Needs the 'rl' extra.")
    src = ex.add_mutually_exclusive_group(required=True)
    src.add_argument("--run-dir", type=Path, help="folder written by `vtrack train` (its model.zip and "
                     "vecnormalize.pkl are unpickled: another machine's run folder needs --trust)")
    src.add_argument("--model", type=Path, help="an SB3 model file (model.zip) of a PPO/SAC/TD3 MlpPolicy; it is "
                     "unpickled, so it needs --trust")
    ex.add_argument("--trust", action="store_true",
                    help="unpickle the SB3 files even though vtrack cannot vouch for them (a --model file, a run "
                    "folder copied from elsewhere or changed since training): only for files you trust")
    ex.add_argument("--algo", choices=("ppo", "sac", "td3"), default=None, help="algorithm of --model (required "
                    "with --model)")
    ex.add_argument("--vecnormalize", type=Path, default=None,
                    help="with --model: the VecNormalize statistics (vecnormalize.pkl) the model was trained with")
    ex.add_argument("--env", default="LateralTrackingRandom-v0",
                    help="with --model: the env whose contract the file records (default: %(default)s)")
    ex.add_argument("--control-period-s", type=_float_in(1e-3, 1.0), default=None,
                    help="with --model: the decision period [s] the model was trained at (e.g. 0.05 for the "
                    "TrainingMix-v0 recipes; default: the --env's own, said on stderr)")
    ex.add_argument("--raw-observations", action="store_true",
                    help="with --model and no --vecnormalize: the model was trained on raw observations (skips "
                    "the refusal when a vecnormalize.pkl lies next to it or its observation space looks scaled)")
    ex.add_argument("--out", type=Path, required=True, help="output path without suffix, e.g. agents/ppo_dlc")

    pl = sub.add_parser("plot", help="write the paper's figures for some policies",
                        description="Roll out the given policies on one env and write trajectory, signal and "
                        "deviation-rate figures.")
    pl.add_argument("--policies", default="smc,mpc", help="comma-separated policy names (default: smc,mpc)")
    pl.add_argument("--env", default=None,
                    help="env id, also highway-env:lane-keeping-v0 (default: LateralTracking-v0, or --track)")
    _add_track(pl)
    pl.add_argument("--out", type=Path, default=DEFAULT_PLOTS_DIR,
                    help=f"output folder (default: {DEFAULT_PLOTS_DIR}; the benchmark's figures are left alone)")

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
    t.add_argument("--generations", type=_int_in(1, 10_000), default=None,
                   help="override the budget's generations (1-10000)")
    t.add_argument("--pop-size", type=_int_in(2, 10_000), default=None,
                   help="override the budget's population size (2-10000)")
    t.add_argument("--seed", type=_int_in(0, MAX_RNG_SEED), default=0, help="GA seed, 0 to 2^32-1 (default: 0)")
    t.add_argument("--comfort-weight", type=_float_in(0.0, 1e6), default=0.0,
                   help="weight of the ISO 2631-1 comfort a_v in the fitness (default: 0 = off)")
    t.add_argument("--out", type=Path, default=None,
                   help="preset file to write (default: vtrack_results/<controller>_tuned.json)")
    t.add_argument("--store", type=Path, default=None,
                   help="also record the result in this leaderboard store (suite 'tuning'; default: none)")
    t.add_argument("--also-complete", default="",
                   help="comma-separated env ids every individual must also complete, e.g. DLC120-v0 (a failure "
                   "adds the incomplete-run penalty; default: none, the paper's Case-1-only fitness)")
    _add_track(t, "a CSV track file every individual must also complete (like --also-complete; local backend)")
    t.add_argument("--max-steps", type=_int_in(1, 10**7), default=None,
                   help="cut every episode after this many steps (smoke tests only; default: full episodes)")
    t.add_argument("--backend", choices=("local", "ray"), default="local",
                   help="where each generation is evaluated: local (one batched rollout in this process) or ray "
                   "(the population split over Ray workers; needs pip install \"vtrack_gym[ray]\"; same result) "
                   "(default: local)")
    t.add_argument("--ray-address", default=None, metavar="ADDR",
                   help="Ray cluster to connect to with --backend ray, e.g. 10.0.0.5:6379 (default: $RAY_ADDRESS "
                   "if set, else a local Ray instance started and stopped by this command)")
    t.add_argument("--workers", type=_int_in(1, 4096), default=None, metavar="N",
                   help="Ray workers with --backend ray (default: the cluster's CPU count, at most the population "
                   "size)")
    t.add_argument("--no-progress", action="store_true", help="no progress bar")

    vd = sub.add_parser("video", help="write an MP4 or GIF of policies driving a scenario (extra 'render')",
                        description="Drive one or more policies on one env (same seed) and write a top-down video: "
                        "MP4 through imageio-ffmpeg or GIF through Pillow, at real time or --speedup. Several "
                        "policies are shown side by side (one panel each) or overlaid in one frame.")
    vd.add_argument("--policy", default=None, help="one policy name or agent file (as for `vtrack eval`)")
    vd.add_argument("--policies", default=None, help="comma-separated policy names, e.g. mpc,smc")
    where = vd.add_mutually_exclusive_group(required=True)
    where.add_argument("--env", default=None, help="env id, e.g. DLC120-v0 or LateralTracking-v0")
    _add_track(vd, where=where)
    vd.add_argument("--out", type=Path, required=True, help="output file ending in .mp4 or .gif")
    vd.add_argument("--preset", default="default", help="baseline preset for every policy (default: default)")
    _add_vehicle(vd)
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
    r.add_argument("--out", type=Path, default=DEFAULT_RESULTS_DIR,
                   help=f"output folder (default: {DEFAULT_RESULTS_DIR}; `--out docs` regenerates the shipped report)")
    return parser


_EXTRAS: dict[str, tuple[str, str]] = {
    "matplotlib": ("benchmark", "the figures"), "osqp": ("benchmark", "the mpc_osqp baseline"),
    "highway_env": ("highway", "highway-env's lane-keeping-v0"), "stable_baselines3": ("rl", "SB3 training"),
    "torch": ("rl", "SB3 training"), "yaml": ("rl", "the hyperparameter files"), "pymoo": ("tuning", "the GA"),
}
"""Importable module -> (extra that installs it, what needs it)."""
TORCH_HINT = ("The rl extra brings PyTorch: without an NVIDIA GPU, install its CPU build first (pip install torch "
              "--index-url https://download.pytorch.org/whl/cpu); for a GPU build pick your platform and CUDA "
              "version at https://pytorch.org/get-started/locally/ (a plain `pip install torch` pulls the CUDA "
              "build, several GB, on Linux).")
"""Said with every message that names the ``rl`` extra."""


def _needed_modules(args: argparse.Namespace) -> list[str]:
    """The optional modules the chosen command will import, from its arguments alone."""
    cmd = args.command
    needed: list[str] = []
    policies: list[str] = []
    if cmd == "benchmark":
        policies = _policy_list(args.policies) or ["mpc_osqp"]
        needed += [] if args.no_figures else ["matplotlib"]
        needed += ["highway_env"] if args.suite == "highway" and args.track is None else []
    elif cmd in ("eval", "plot"):
        policies = [args.policy] if cmd == "eval" else _policy_list(args.policies)
        needed += ["matplotlib"] if cmd == "plot" else []
        needed += ["highway_env"] if "highway" in (args.env or "") else []
    elif cmd == "reproduce":
        needed += ["matplotlib"]
    elif cmd in ("train", "export"):
        needed += ["stable_baselines3", "torch", "yaml"]
    elif cmd == "tune":
        needed += ["pymoo"]
    needed += ["osqp"] if any(p.partition(":")[0] == "mpc_osqp" for p in policies) else []
    return needed


def _policy_list(text: str) -> list[str]:
    """The names of a comma-separated ``--policies`` value (spaces around the names ignored, empty items dropped)."""
    return [p.strip() for p in text.split(",") if p.strip()]


def _missing_packages(args: argparse.Namespace) -> str:
    """'' if every optional package the command needs is installed, else which are missing and the extra."""
    import importlib.util

    missing = [m for m in dict.fromkeys(_needed_modules(args)) if importlib.util.find_spec(m) is None]
    if not missing:
        return ""
    extras = sorted({_EXTRAS[m][0] for m in missing})
    what = "; ".join(f"{m} ({_EXTRAS[m][1]})" for m in missing)
    hint = " or pass --no-figures" if args.command == "benchmark" and "matplotlib" in missing else ""
    torch = f". {TORCH_HINT}" if "rl" in extras else ""
    return (f"missing optional packages: {what}. Install them with: pip install "
            + " ".join(f'"vtrack_gym[{e}]"' for e in extras) + hint + torch)


def _render_board(board: list[dict], fmt: str, title: str = "vtrack leaderboard",
                  figures: Sequence[Path] = (), notes: Sequence[str] = ()) -> str:
    from vtrack_gym.evaluation import report_formats as rf

    if fmt == "html":
        from vtrack_gym.evaluation.html_report import to_html

        return to_html(board, title=title, figures=figures, notes=notes)
    return {"md": rf.to_markdown, "csv": rf.to_csv, "json": rf.to_json, "latex": rf.to_latex}[fmt](board).rstrip()


def _print_board(board: list[dict], fmt: str) -> None:
    print(_render_board(board, fmt))


def _cmd_benchmark(args: argparse.Namespace) -> int:
    from vtrack_gym.evaluation.benchmark import policy_factories, run_benchmark, suite_columns, summarise
    from vtrack_gym.evaluation.store import ResultStore

    if args.track is not None and (args.suite is not None or args.quick):
        given = " and ".join(o for o, on in (("--suite", args.suite is not None), ("--quick", args.quick)) if on)
        raise ValueError(f"--track scores the policies on the track file (suite 'custom'); it cannot be combined "
                         f"with {given} (--seeds may be given: one episode per seed)")
    args.suite = args.suite or "paper"
    seeds = _parse_seeds(args.seeds) if args.seeds is not None else None
    policies = _policy_list(args.policies) or None
    if policies:
        policy_factories(policies)  # every name checked before any work
    _check_vehicle(args)
    store = ResultStore(args.store)  # verified before any rollout; written after the table is printed
    _announce_kernels()
    if args.track is not None:
        result = _benchmark_track(args, policies, seeds or [0])
    else:
        result = run_benchmark(args.suite, store=None, policies=policies,
                               figures_dir=None if args.no_figures else args.figures, quick=args.quick, seeds=seeds,
                               vehicle=args.vehicle)
    suite = "custom" if args.track is not None else result["suite"]
    if suite != args.suite and args.track is None:
        print(f"suite {suite!r}: not the standard {args.suite} episodes, so stored and ranked apart from the "
              f"{args.suite!r} board (vtrack leaderboard --suite '{suite}')", file=sys.stderr)
    _print_board(summarise(result["rows"], suite_columns(suite)), args.format)
    print(_ranking_note(suite), file=sys.stderr)
    for f in result["figures"]:
        print(f"figure: {f}", file=sys.stderr)
    sys.stdout.flush()
    store.add(result["rows"])
    print(f"\nresults stored in {args.store} (suite {suite!r})", file=sys.stderr)
    return 0


def _ranking_note(suite: str) -> str:
    from vtrack_gym.evaluation.board import ranking_note
    from vtrack_gym.evaluation.suites import primary_metric

    return ranking_note(primary_metric(suite))


def _seed_text_ok(text: str) -> bool:
    """``text`` is a decimal integer in [0, 2^63 - 1] (checked on the text first: no 5000-digit conversions)."""
    return len(text) <= 19 and text.isascii() and text.isdigit() and int(text) <= MAX_SEED


def _parse_seeds(text: str) -> list[int]:
    """Seeds from ``0-9`` / ``0,3,5`` / ``0-4,10`` (integers in [0, 2^63 - 1], ranges inclusive, duplicates
    dropped); ``ValueError`` naming the bad item (before any work)."""
    seeds: list[int] = []
    for item in (t.strip() for t in text.split(",")):
        if not item:
            continue
        lo, sep, hi = item.partition("-")
        lo, hi = lo.strip(), hi.strip()
        if not _seed_text_ok(lo) or (sep and not _seed_text_ok(hi)):
            raise ValueError(f"--seeds must be integers in [0, 2^63 - 1 = {MAX_SEED}] or ranges A-B, "
                             f"comma-separated, e.g. 0-9 or 0,3,5 (got {item[:40]!r})")
        first, last = int(lo), int(hi) if sep else int(lo)
        if last < first or last - first >= MAX_SEEDS:
            raise ValueError(f"--seeds range {item!r} must go up (A <= B) and take at most {MAX_SEEDS} seeds")
        seeds.extend(range(first, last + 1))
    seeds = list(dict.fromkeys(seeds))
    if not seeds:
        raise ValueError("--seeds needs at least one seed, e.g. --seeds 0-4 or --seeds 0,1,2")
    if len(seeds) > MAX_SEEDS:
        raise ValueError(f"--seeds takes at most {MAX_SEEDS} seeds (got {len(seeds)})")
    return seeds


MIN_SPEED_KMH = 3.6 * MIN_V_REF_MPS
"""--max-speed-kmh range [km/h]: the speed profiles' floor (1 m/s) ..."""
MAX_SPEED_KMH = 3.6 * MAX_V_REF_MPS
"""... to their ceiling (150 m/s)."""
MAX_LATERAL_G = MAX_ACCEL_MPS2 / GRAVITY_MPS2
"""--max-lateral-g upper bound [g] (the profiles' 30 m/s^2)."""


def _add_track(p: argparse.ArgumentParser, text: str | None = None, where: Any = None) -> None:
    """``--track FILE`` (in the group ``where`` if given, e.g. exclusive with --env), how it is read and its
    speed-profile options."""
    from vtrack_gym.envs.scenarios import MAX_TRACK_SMOOTHING_M

    (where if where is not None else p).add_argument("--track", type=Path, default=None, metavar="FILE",
                   help=text or "drive on this CSV track file instead of --env (columns by header: x_m, y_m, optional "
                   "z_m, w_tr_right_m, w_tr_left_m, v_mps; vtrack/Track-v0)")
    p.add_argument("--track-closed", choices=("auto", "yes", "no"), default="auto",
                   help="--track: read the file as a closed loop (yes), an open road (no) or decide from the end gap "
                   "against the point spacing (auto; the decision is printed) (default: auto)")
    p.add_argument("--track-smoothing-m", type=float, default=None, metavar="M",
                   help="--track: RMS deviation [m] the spline fit may make from the file's points, for noisy "
                   f"coordinates (e.g. GPS; 0 interpolates; at most {MAX_TRACK_SMOOTHING_M:g} m) (default: chosen "
                   "from the coordinates' rounding)")
    p.add_argument("--speed-profile", choices=("constant", "curvature", "file"), default="curvature",
                   help="--track: target speed: constant (--max-speed-kmh), curvature (the fastest profile within "
                   "--max-speed-kmh and --max-lateral-g, 2 m/s^2 up, 3 m/s^2 down) or file (the v_mps column; "
                   "takes neither option) (default: curvature)")
    p.add_argument("--max-speed-kmh", type=float, default=None,
                   help=f"--track with --speed-profile constant or curvature: maximum speed [km/h], "
                   f"{MIN_SPEED_KMH:g} to {MAX_SPEED_KMH:g} (default: 40)")
    p.add_argument("--max-lateral-g", type=float, default=None,
                   help=f"--track with --speed-profile curvature: lateral acceleration limit [g], > 0 and <= "
                   f"{MAX_LATERAL_G:.2f} (default: 0.7)")


def _speed_profile(args: argparse.Namespace):
    """The tracks speed profile of --speed-profile / --max-speed-kmh / --max-lateral-g; ValueError naming the
    option, its range in its own units, or an option the profile does not use."""
    from vtrack_gym.envs.scenarios import KMH
    from vtrack_gym.tracks import ConstantSpeed, CurvatureLimited, FileSpeed
    from vtrack_gym.vehicle.params import GRAVITY_MPS2

    unused = {"file": ("--max-speed-kmh", "--max-lateral-g"), "constant": ("--max-lateral-g",)}.get(
        args.speed_profile, ())
    for name in unused:
        if getattr(args, name[2:].replace("-", "_")) is not None:
            what = "the file's v_mps column sets the speeds" if args.speed_profile == "file" else "no curves limit it"
            raise ValueError(f"{name} does not apply to --speed-profile {args.speed_profile} ({what}); fix: drop "
                             f"{name}, or use --speed-profile curvature")
    speed_kmh = 40.0 if args.max_speed_kmh is None else args.max_speed_kmh
    lateral_g = 0.7 if args.max_lateral_g is None else args.max_lateral_g
    if not MIN_SPEED_KMH <= speed_kmh <= MAX_SPEED_KMH:
        raise ValueError(f"--max-speed-kmh must be in [{MIN_SPEED_KMH:g}, {MAX_SPEED_KMH:g}] km/h (got {speed_kmh})")
    if not 0.0 < lateral_g <= MAX_LATERAL_G:
        raise ValueError(f"--max-lateral-g must be in (0, {MAX_LATERAL_G:.2f}] g (got {lateral_g})")
    if args.speed_profile == "constant":
        return ConstantSpeed(speed_kmh * KMH)
    if args.speed_profile == "file":
        return FileSpeed()
    return CurvatureLimited(speed_kmh * KMH, lateral_g * GRAVITY_MPS2)


def _track_read(args: argparse.Namespace) -> dict[str, Any]:
    """``load_track`` options of --track-closed / --track-smoothing-m (only those given)."""
    from vtrack_gym.envs.scenarios import MAX_TRACK_SMOOTHING_M

    read: dict[str, Any] = {}
    if args.track_closed != "auto":
        read["closed"] = args.track_closed == "yes"
    m = args.track_smoothing_m
    if m is not None:
        if not 0.0 <= m <= MAX_TRACK_SMOOTHING_M:
            raise ValueError(f"--track-smoothing-m must be in [0, {MAX_TRACK_SMOOTHING_M:g}] m (got {m})")
        read["smoothing_m"] = float(m)
    return read


def _describe_track(file: Path, read: dict[str, Any]) -> str:
    """One line saying how --track was read: closed loop or open road, its length and point count."""
    from vtrack_gym.tracks import load_track
    from vtrack_gym.tracks.csv_loader import read_track_columns

    path = load_track(file, **read)
    n_points = len(read_track_columns(Path(file))[1])
    how = "forced by --track-closed" if "closed" in read else "detected; --track-closed yes/no forces it"
    kind = "a closed loop" if path.closed else "an open road"
    return f"--track {file}: read as {kind} ({how}), {path.length_m:.1f} m, {n_points} points"


def _add_vehicle(p: argparse.ArgumentParser) -> None:
    """``--vehicle NAME|FILE``: the car (a shipped vehicle or a vehicle JSON file; default the paper's car)."""
    from vtrack_gym.vehicle.catalog import list_vehicles

    p.add_argument("--vehicle", default=None, metavar="NAME|FILE",
                   help=f"the car: {', '.join(list_vehicles())} or a vehicle .json file (default: the paper's "
                   "hatchback); recorded in the rows' options, so cars are ranked apart")


def _check_vehicle(args: argparse.Namespace) -> None:
    """Load ``--vehicle`` once before any work (a clear error for an unknown name or a bad file)."""
    if getattr(args, "vehicle", None) is not None:
        from vtrack_gym.vehicle.catalog import load_vehicle

        load_vehicle(args.vehicle)


def _env_or_track(args: argparse.Namespace, default: str | None = None) -> tuple[str, dict[str, Any]]:
    """The env id of ``--env`` or ``--track`` (registered for this track file and profile) and the provenance to
    record in the rows' options (empty for ``--env``)."""
    from vtrack_gym.interop import resolve_env_id

    if args.track is not None:
        if getattr(args, "env", None) is not None:
            raise ValueError("give --env or --track, not both")
        from vtrack_gym.envs.registration import register_track

        profile, read = _speed_profile(args), _track_read(args)
        print(_describe_track(args.track, read), file=sys.stderr)
        return register_track(args.track, profile, **read)
    env = args.env if args.env is not None else default
    if env is None:
        raise ValueError("give --env ID (e.g. DLC120-v0) or --track FILE")
    return _known_env(resolve_env_id(env)), {}


def _with_provenance(rows: list, provenance: dict[str, Any]) -> list:
    """Rows with the track's provenance added to their ``options`` (no store schema change)."""
    if not provenance:
        return rows
    import dataclasses

    return [dataclasses.replace(r, options={**r.options, **provenance}) for r in rows]


def _benchmark_track(args: argparse.Namespace, policies: list[str] | None, seeds: Sequence[int]) -> dict[str, Any]:
    """``vtrack benchmark --track``: every policy on the track, one episode per seed (suite 'custom'), rows with
    provenance; the figures show the first seed's episodes."""
    from vtrack_gym.evaluation.benchmark import policy_factories, score_policy, write_figures
    from vtrack_gym.evaluation.suites import Episode

    env_id, provenance = _env_or_track(args)
    episodes = [Episode(env_id, int(s), vehicle=args.vehicle) for s in seeds]
    rows, traces = [], []
    for name, make in policy_factories(policies).items():
        r, t = score_policy(name, make, episodes, "custom")
        rows += _with_provenance(r, provenance)
        traces += [tr for tr in t if tr.seed == episodes[0].seed]
    figures = [] if args.no_figures else write_figures({env_id: traces}, rows, args.figures, vehicle=args.vehicle)
    return {"rows": rows, "traces": {env_id: traces}, "figures": figures, "suite": "custom"}


def _known_env(env_id: str) -> str:
    """``env_id`` if Gymnasium knows it (vtrack ids, the highway adapter), else a ValueError listing ours."""
    from gymnasium.envs.registration import registry

    import vtrack_gym

    if env_id not in registry:
        raise ValueError(f"unknown --env {env_id!r}; vtrack envs: {', '.join(vtrack_gym.ENV_IDS)}, "
                         "highway-env:lane-keeping-v0")
    return env_id


def _cmd_eval(args: argparse.Namespace) -> int:
    from vtrack_gym.baselines.resolve import canonical_spec
    from vtrack_gym.evaluation.api import evaluate
    from vtrack_gym.evaluation.report_formats import to_markdown
    from vtrack_gym.evaluation.store import ResultStore

    seeds = _parse_seeds(args.seeds)
    make = _policy_factory(args.policy, args.preset, trust_code=args.trust_code)
    env_id, provenance = _env_or_track(args)
    _check_vehicle(args)
    store = ResultStore(args.store)  # verified before the rollouts; written after the table is printed
    _announce_kernels()
    policy_id = args.policy if args.trust_code else canonical_spec(args.policy, args.preset)
    rows = _with_provenance(evaluate(make, env_id, seeds, policy_id=policy_id, vehicle=args.vehicle), provenance)
    table = [{"seed": r.seed, "termination": r.termination, "success": int(r.verdict()),
              **{k: v for k, v in r.metrics.items() if isinstance(v, float)}} for r in rows]
    print(to_markdown(table), flush=True)
    if len(rows) > 1:
        from vtrack_gym.evaluation.benchmark import LEADERBOARD_COLUMNS, summarise

        print("\n" + to_markdown(summarise(rows, LEADERBOARD_COLUMNS)), flush=True)
    store.add(rows)
    print(f"results stored in {args.store} (suite 'custom': vtrack leaderboard --suite custom)", file=sys.stderr)
    return 0


_USER_SPEC = re.compile(r"[A-Za-z_][\w.]*:[A-Za-z_]\w*")


def _policy_factory(name: str, preset: str, trust_code: bool = False):
    """``make(env) -> policy`` for a ``--policy`` value: the package's resolver, or user code with --trust-code."""
    from vtrack_gym.baselines.registry import available_policies
    from vtrack_gym.baselines.resolve import policy_factory

    module, sep, _ = name.partition(":")
    if sep and module not in available_policies() and _USER_SPEC.fullmatch(name) and not Path(name).exists():
        if not trust_code:
            raise ValueError(f"--policy {name!r} names Python code (MODULE:NAME); importing it runs that code, so "
                             "vtrack does it only with --trust-code")
        if preset != "default":
            raise ValueError("--preset applies to the baselines, not to MODULE:NAME")
        return _user_factory(name)
    if trust_code:
        raise ValueError("--trust-code applies to --policy MODULE:NAME only")
    return policy_factory(name, preset)


def _user_factory(spec: str):
    """Import ``MODULE`` (working directory first on the path) and return ``make(env)`` calling ``NAME``."""
    import importlib
    import inspect
    import os

    module_name, _, attr = spec.partition(":")
    print(f"--trust-code: importing and running your module {module_name!r} (policy {attr})", file=sys.stderr)
    if os.getcwd() not in sys.path:
        sys.path.insert(0, os.getcwd())
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise ValueError(f"--policy {spec!r}: cannot import module {module_name!r} ({exc})") from None
    obj = getattr(module, attr, None)
    if obj is None:
        raise ValueError(f"--policy {spec!r}: module {module_name!r} has no attribute {attr!r}")
    if hasattr(obj, "predict") and not inspect.isclass(obj):
        return lambda env: obj
    if not callable(obj):
        raise ValueError(f"--policy {spec!r}: {attr} is neither a class, a function nor an object with predict")
    try:
        params = [p for p in inspect.signature(obj).parameters.values()
                  if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
    except (TypeError, ValueError):
        params = []
    return (lambda env: obj(env)) if params else (lambda env: obj())


def _announce_kernels() -> None:
    """Say that the first rollout compiles the numba kernels when no compiled cache exists yet."""
    import os

    import vtrack_gym

    cache_dir = os.environ.get("NUMBA_CACHE_DIR")
    root = Path(cache_dir) if cache_dir else Path(vtrack_gym.__file__).parent
    log = logging.getLogger("vtrack_gym.cli")
    if not any(root.glob("**/*.nbi")):
        log.info("compiling the kernels (first run only, ~30 s)")
    else:
        log.debug("loading the compiled kernels from the numba cache")


def _cmd_leaderboard(args: argparse.Namespace) -> int:
    from vtrack_gym.evaluation.benchmark import suite_columns
    from vtrack_gym.evaluation.store import ResultStore

    if not args.store.exists():
        print(f"no store at {args.store}: run `vtrack benchmark` first (or pass --store)", file=sys.stderr)
        return 2
    if not args.store.is_dir():  # a directory is the store's own error (StoreError)
        check_regular_input(args.store, "store (--store)")
    store = ResultStore(args.store, read_only=True)
    suites = store.suites()
    listing = ", ".join(f"{name} ({n} episodes)" for name, n in suites.items()) or "none"
    if args.suite not in suites:
        raise ValueError(f"no suite {args.suite!r} in {args.store}; suites present: {listing}. Select one with "
                         "--suite NAME")
    print(f"suite {args.suite!r} of {args.store}; suites present: {listing} (select one with --suite NAME)",
          file=sys.stderr)
    board = store.leaderboard(args.suite, suite_columns(args.suite), latest_only=not args.all_versions)
    figures = sorted(f for f in args.figures.glob("*.png") if f.is_file() and f.stat().st_size <= MAX_FIGURE_BYTES) \
        if args.format == "html" and args.figures.is_dir() else []  # regular files only: a FIFO would block
    note = _ranking_note(args.suite)
    newest, hidden = store.older_versions(args.suite)
    if hidden and not args.all_versions:
        note += (f" Only rows of the newest package version ({newest}) are shown: {hidden} row(s) of older versions "
                 "are hidden; --all-versions shows them.")
    print(note, file=sys.stderr)
    text = _render_board(board, args.format, title=f"vtrack leaderboard: suite {args.suite}", figures=figures,
                         notes=[note])
    if args.out is None:
        print(text.rstrip())
        return 0
    try:
        write_atomic(args.out, text if text.endswith("\n") else text + "\n", "--out")
    except OSError as exc:
        raise ValueError(f"cannot write --out {args.out}: {exc}") from None
    print(f"leaderboard written to {args.out}", file=sys.stderr)
    return 0


def _cmd_plot(args: argparse.Namespace) -> int:
    from vtrack_gym.evaluation.benchmark import score_policy, write_figures
    from vtrack_gym.evaluation.suites import Episode

    env_id, _ = _env_or_track(args, default="LateralTracking-v0")
    names = _policy_list(args.policies)
    if not names:
        raise ValueError("--policies needs at least one policy name, e.g. --policies smc,mpc")
    makes = {name: _policy_factory(name, "default") for name in names}  # every name checked before any rollout
    _announce_kernels()
    rows, traces = [], []
    for name, make in makes.items():
        r, t = score_policy(name, make, [Episode(env_id, 0)], "custom")
        rows += r
        traces += t
    for f in write_figures({env_id: traces}, rows, args.out):
        print(f"figure: {f}")
    return 0


def _cmd_video(args: argparse.Namespace) -> int:
    from vtrack_gym.envs.render import RenderConfig
    from vtrack_gym.evaluation.video import VideoConfig, check_video_path, record_video

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
    from vtrack_gym.envs.registration import TRACK_ID_PREFIX

    env_id, _ = _env_or_track(args)
    if env_id not in vtrack_gym.ALL_ENV_IDS and not env_id.startswith(TRACK_ID_PREFIX):
        raise ValueError(f"vtrack video draws the vtrack envs only: {', '.join(vtrack_gym.ENV_IDS)} (got --env "
                         f"{args.env!r})")
    names = [args.policy] if args.policy is not None else [p.strip() for p in args.policies.split(",") if p.strip()]
    if not names:
        raise ValueError("--policies needs at least one policy name, e.g. --policies mpc,smc")
    policies = [(Path(n).stem if Path(n).suffix else n, _policy_factory(n, args.preset)) for n in names]
    _check_vehicle(args)
    result = record_video(env_id, policies, out, config, seed=args.seed,
                          progress=lambda msg: print(f"recording: {msg}", file=sys.stderr), vehicle=args.vehicle)
    print(f"video: {result['path']} ({result['frames']} frames, {result['video_s']:.1f} s of video for "
          f"{result['driven_s']:.1f} s of driving, written in {result['wall_s']:.1f} s)")
    return 0


def _cmd_tune(args: argparse.Namespace) -> int:
    import json
    import shlex

    from vtrack_gym.tuning.job import tune_to_preset

    if args.backend != "ray" and (args.ray_address is not None or args.workers is not None):
        raise ValueError("--ray-address and --workers need --backend ray")
    also = [e for e in args.also_complete.split(",") if e]
    if args.track is not None:  # every individual must also complete the track (ids of this process: local only)
        if args.backend == "ray":
            raise ValueError("--track needs --backend local (the track's env id is registered in this process)")
        also.append(_env_or_track(args)[0])
    command = "vtrack " + " ".join(shlex.quote(a) for a in (sys.argv[1:] if args.argv is None else args.argv))
    outcome = tune_to_preset(
        args.controller, args.space, args.budget, seed=args.seed, generations=args.generations,
        pop_size=args.pop_size, comfort_weight=args.comfort_weight, max_steps=args.max_steps,
        also_complete=tuple(also), backend=args.backend,
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


MAX_SET_CHARS = 4096
"""Longest ``--set`` VALUE [characters]."""


def _check_set_value(key: str, value: object, depth: int = 0) -> None:
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
            _check_set_value(key, k, depth + 1)
            _check_set_value(key, v, depth + 1)
    elif isinstance(value, (list, tuple)):
        for v in value:
            _check_set_value(key, v, depth + 1)


def _parse_hyperparams(items: Sequence[str]) -> dict[str, object]:
    """``--set KEY=VALUE`` items as a dict, each VALUE read with ``yaml.safe_load`` (never evaluated)."""
    import yaml

    out: dict[str, object] = {}
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
        _check_set_value(key.strip(), value)
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
                    final_eval=not args.no_final_eval, bc=bc, overwrite=args.overwrite)
    print(json.dumps({k: v for k, v in summary.items() if k not in ("model", "vecnormalize")}, indent=2,
                     default=str))
    if summary.get("interrupted"):
        print(f"vtrack train: interrupted at {summary['timesteps']} timesteps; the model as it was is saved in "
              f"{args.run_dir}/model.zip and exported to {summary['agent']} (config.json: interrupted: true). "
              f"`vtrack eval --policy {summary['agent']}` evaluates it, `vtrack export --run-dir {args.run_dir}` "
              "re-exports it", file=sys.stderr)
        return 130
    return 0


def _cmd_export(args: argparse.Namespace) -> int:
    import json

    from vtrack_gym.agents.export import export_model, export_run

    if args.run_dir is not None:
        if args.algo or args.vecnormalize or args.control_period_s is not None or args.raw_observations:
            raise ValueError("--algo, --vecnormalize, --control-period-s and --raw-observations go with --model; "
                             "--run-dir reads them from the run")
        json_path, npz_path = export_run(args.run_dir, args.out, trust=args.trust)
    else:
        if args.algo is None:
            raise ValueError("--model needs --algo (ppo, sac or td3)")
        if not args.trust:
            raise ValueError(f"--model {args.model} is an SB3 pickle: loading it runs any code it contains. Pass "
                             "--trust if you produced it or trust its source (or export a `vtrack train` run "
                             "folder of this machine with --run-dir)")
        _known_env(args.env)
        if args.vecnormalize is not None and args.raw_observations:
            raise ValueError("--raw-observations contradicts --vecnormalize: pass one of them")
        env_kwargs = None if args.control_period_s is None else {"control_period_s": args.control_period_s}
        json_path, npz_path = export_model(args.model, args.out, args.algo, args.vecnormalize, env_id=args.env,
                                           command="vtrack export --model " + str(args.model), env_kwargs=env_kwargs,
                                           raw_observations=args.raw_observations)
        spec = json.loads(json_path.read_text(encoding="utf-8"))
        if args.control_period_s is None and "env" in spec:
            print(f"vtrack export: note: decision period {spec['env']['control_period_s']:g} s, {args.env}'s own "
                  "(pass --control-period-s if the model was trained at another)", file=sys.stderr)
        if args.vecnormalize is None:
            print("vtrack export: note: the agent takes raw observations (no --vecnormalize)", file=sys.stderr)
    print(json.dumps({"json": str(json_path), "npz": str(npz_path)}))
    return 0


def _check_outputs(args: argparse.Namespace) -> None:
    """Every output location of the command checked (and missing folders created) before any work starts."""
    cmd = args.command
    if cmd in ("benchmark", "eval"):
        check_output_file(args.store, "--store")
    if cmd == "benchmark" and not args.no_figures:
        check_output_dir(args.figures, "--figures")
    if cmd == "leaderboard" and args.out is not None:
        _check_board_out(args.out, args.store)
    if cmd == "plot":
        check_output_dir(args.out, "--out")
    if cmd == "train":
        from vtrack_gym.agents.train import RUN_FILES, check_run_dir

        check_output_dir(args.run_dir, "--run-dir")
        for name in RUN_FILES:  # each must be absent or a regular file
            check_output_file(args.run_dir / name, "--run-dir")
        check_run_dir(args.run_dir, args.overwrite)  # refused before any work; removed by train() with --overwrite
    if cmd == "export":
        for suffix in (".json", ".npz"):
            check_output_file(args.out.parent / (args.out.name + suffix), "--out")
    if cmd == "reproduce":
        check_output_dir(args.out / "reproduction", "--out")
        check_output_file(args.out / "REPRODUCTION.md", "--out")
    if cmd == "tune":
        check_output_file(args.out or DEFAULT_RESULTS_DIR / f"{args.controller}_tuned.json", "--out")
        if args.store is not None:
            check_output_file(args.store, "--store")


SQLITE_HEADER = b"SQLite format 3\x00"
"""The first 16 bytes of every SQLite database file."""
STORE_COMPANIONS = ("", "-wal", "-shm", "-journal")
"""Suffixes of a store's file and of the files SQLite keeps next to it."""


def _same_file(a: Path, b: Path) -> bool:
    """``a`` and ``b`` are one file: the same path after resolving symlinks, or hard links of one inode."""
    import os

    if os.path.realpath(a) == os.path.realpath(b):
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:  # one of them does not exist
        return False


def _check_board_out(out: Path, store: Path) -> None:
    """``leaderboard --out``: a writable regular file that is neither the store nor one of its ``-wal``/``-shm``/
    ``-journal`` files, and not an existing SQLite database (``ValueError`` naming --out otherwise)."""
    for suffix in STORE_COMPANIONS:
        companion = store.with_name(store.name + suffix)
        if _same_file(out, companion):
            what = "the store" if not suffix else f"the store's {suffix[1:]} file"
            raise ValueError(f"--out {out} is {what} (--store {store}); `vtrack leaderboard` never changes a store: "
                             "pass another --out file (e.g. board.md), or omit --out to print to stdout")
    check_output_file(out, "--out")
    try:
        with open(out, "rb") as fh:
            header = fh.read(len(SQLITE_HEADER))
    except FileNotFoundError:
        return
    except OSError as exc:
        raise ValueError(f"--out {out}: cannot read the existing file ({exc.strerror or exc})") from None
    if header == SQLITE_HEADER:
        raise ValueError(f"--out {out} is an existing SQLite database (a store?); it is never overwritten: pass "
                         "another --out file (e.g. board.md)")


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``vtrack``; returns the process exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    args.argv = None if argv is None else list(argv)
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(message)s")
    # the package says what its long phases do (INFO); -v adds every episode's result and the details (DEBUG)
    logging.getLogger("vtrack_gym").setLevel(logging.DEBUG if args.verbose else logging.INFO)
    import vtrack_gym  # noqa: F401  (registers the env ids)

    missing = _missing_packages(args)
    if missing:
        print(f"vtrack {args.command}: error: {missing}", file=sys.stderr)
        return 2

    handlers = {"benchmark": _cmd_benchmark, "eval": _cmd_eval, "leaderboard": _cmd_leaderboard, "plot": _cmd_plot,
                "train": _cmd_train, "export": _cmd_export, "video": _cmd_video,
                "tune": _cmd_tune, "reproduce": _cmd_reproduce}
    try:
        _check_outputs(args)
        return handlers[args.command](args)
    except (ValueError, FileNotFoundError, ImportError, StoreError, sqlite3.Error, BackendError) as exc:
        print(f"vtrack {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
