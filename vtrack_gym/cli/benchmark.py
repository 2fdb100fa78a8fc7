"""``vtrack benchmark``: every baseline and shipped agent (or --policies) on a suite, a track file or a set of track
files, in local processes or on Ray."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from vtrack_gym._io import check_output_dir, check_output_file
from vtrack_gym.cli import _options as opt
from vtrack_gym.cli._board import ranking_note, render_board, report_lost, shown_columns
from vtrack_gym.cli._envs import (
    announce_kernels,
    check_vehicle,
    env_or_track,
    speed_profile,
    track_limits,
    track_read,
)
from vtrack_gym.cli._extras import osqp_for
from vtrack_gym.cli._policies import policy_factories
from vtrack_gym.cli._terminal import err, out
from vtrack_gym.evaluation.storage.store import StoreError
from vtrack_gym.evaluation.suite.suites import get_suite, quick_suites, seeds_help, suite_help, suite_names

NAME = "benchmark"
EXIT_TRACKS_REFUSED = 3
"""Exit status of ``--tracks`` when some files were refused (the rest ran and were stored)."""


def register(sub: Any) -> None:
    b = sub.add_parser(NAME, help="score every baseline and shipped agent on a suite; print the leaderboard",
                       description="Run every baseline policy (default presets) and every shipped RL agent on the "
                       "suite's episodes, store the results, print the leaderboard and write the figures.")
    b.add_argument("--suite", choices=suite_names(), default=None,
                   help=f"{suite_help()} (default: paper; not with --track)")
    b.add_argument("--policies", default="",
                   help="comma-separated policy names to score (default: all; see `vtrack eval --help`)")
    opt.add_user_code(b)
    b.add_argument("--figures", type=Path, default=opt.DEFAULT_FIGURES_DIR,
                   help=f"root folder of the PNG figures: each run writes its own folder <suite>/<policies>-<digest> "
                   f"below it, recorded in its rows (default: {opt.DEFAULT_FIGURES_DIR})")
    b.add_argument("--no-figures", action="store_true", help="skip the figures")
    b.add_argument("--quick", action="store_true", help=f"suites with a quick variant ({', '.join(quick_suites())}): "
                   "fewer seeds (stored as suite NAME[quick], apart from the standard board)")
    b.add_argument("--seeds", default=None,
                   help=f"episode seeds to score (the env's reset seeds), e.g. 0-9 or 0,3,5 (default: the suite's: "
                   f"{seeds_help()}); the table shows "
                   "95 %% bootstrap intervals; other seeds are stored as suite NAME[seeds=...], apart from the "
                   "standard board")
    opt.add_track(b, "score the policies on this CSV track file (suite 'custom', seed 0 or --seeds) instead of "
                  "--suite (not with --suite or --quick)")
    b.add_argument("--tracks", default=None, metavar="DIR_OR_GLOB",
                   help="score the policies on every track file of this folder (*.csv, *.xodr, *.osm, *.xml, *.gpx) "
                   "or glob pattern (quote it, e.g. 'tracks/*.csv'), read with the --track options; every file is "
                   "read and checked first: refused files are listed with their reasons, the rest run and are "
                   "stored, and the exit status is 3 when some were refused (-v: one line per track); suite "
                   "tracks[<name>-<digest>], whose board ranks across all tracks first and keeps the per-track rows "
                   "(not with --suite, --quick or --track)")
    b.add_argument("--workers", type=opt.int_in(1, opt.MAX_WORKERS), default=None, metavar="N",
                   help=f"run the episodes in at most N local processes, 1 to {opt.MAX_WORKERS} (default: the cores of "
                   "this machine; 1 runs them in this process; never more processes than episodes); the rows do not "
                   "depend on N. With --backend ray: the most episodes in flight")
    b.add_argument("--backend", choices=("local", "ray"), default="local",
                   help="local: processes on this machine; ray: tasks on the Ray cluster of RAY_ADDRESS, or a "
                   "local Ray instance (needs the 'ray' extra) (default: local)")
    opt.add_vehicle(b)
    opt.add_latency(b)
    opt.add_control(b)
    opt.add_launch(b)
    opt.add_numerics(b)
    opt.add_store(b)
    opt.add_format(b)
    opt.add_columns(b)


def needed_modules(args: argparse.Namespace) -> list[str]:
    needed = [] if args.no_figures else ["matplotlib"]
    needed += list(get_suite(args.suite or "paper").needs) if args.track is None and args.tracks is None else []
    needed += ["ray"] if args.backend == "ray" else []
    return needed + osqp_for(opt.policy_list(args.policies) or ["mpc_osqp", "nmpc"])


def check_outputs(args: argparse.Namespace) -> None:
    check_output_file(args.store, "--store", store=True)
    if not args.no_figures:
        check_output_dir(args.figures, "--figures")


def _check_track_options(args: argparse.Namespace) -> None:
    if args.latency is not None and (args.track is not None or args.tracks is not None):
        raise ValueError("--latency applies to a suite's episodes (not --track or --tracks); score a track file "
                         "with compute charged through vtrack eval --track FILE --latency ...")
    if args.launch is not None and (args.track is not None or args.tracks is not None):
        raise ValueError("--launch applies to a suite's episodes (not --track or --tracks)")
    if args.control is not None and (args.track is not None or args.tracks is not None):
        raise ValueError("--control applies to a suite's episodes (not --track or --tracks); score a track file in "
                         "another control mode with vtrack eval --track FILE --control ...")
    if args.numerics is not None and (args.track is not None or args.tracks is not None):
        raise ValueError("--numerics applies to a suite's episodes (not --track or --tracks); score a track file "
                         "with the other plant through vtrack eval --track FILE --numerics ...")
    if args.track_limits is not None and args.track is None and args.tracks is None:
        raise ValueError("--track-limits applies to --track FILE or --tracks DIR_OR_GLOB")
    if args.track is not None and args.tracks is not None:
        raise ValueError("give --track FILE or --tracks DIR_OR_GLOB, not both")
    for option, value, suite in (("--track", args.track, "'custom'"), ("--tracks", args.tracks, "tracks[...]")):
        if value is not None and (args.suite is not None or args.quick):
            given = " and ".join(o for o, on in (("--suite", args.suite is not None), ("--quick", args.quick)) if on)
            raise ValueError(f"{option} scores the policies on the track files (suite {suite}); it cannot be "
                             f"combined with {given} (--seeds may be given: one episode per seed)")


def _check_launch(args: argparse.Namespace, seeds: list[int] | None) -> None:
    """``--launch`` given to the suite's episodes as ``run_benchmark`` will (``ValueError`` before any work when no
    episode holds a speed from rest, or one of them is driven in ``steer``)."""
    if args.launch is None or args.track is not None or args.tracks is not None:
        return
    from vtrack_gym.evaluation.suite.suites import with_control, with_launch

    episodes = with_control(get_suite(args.suite).episodes_for(args.quick, seeds), args.control)
    with_launch(episodes, args.launch, where_it_applies=True)


def _score(args: argparse.Namespace, factories: dict[str, Any] | None, seeds: list[int] | None,
           store: Any) -> dict[str, Any]:
    """Run the benchmark on the track file(s) or the suite (the library does the work; each row is committed to
    ``store`` as its episode ends)."""
    from vtrack_gym.evaluation.benchmarking.benchmark import policy_factories as all_policies
    from vtrack_gym.evaluation.benchmarking.benchmark import run_benchmark
    from vtrack_gym.evaluation.benchmarking.track_benchmark import benchmark_track, benchmark_tracks

    figures = None if args.no_figures else args.figures
    where = {"workers": args.workers, "backend": args.backend, "store": store}
    if args.tracks is not None:
        read = track_read(args)
        return benchmark_tracks(args.tracks, factories or all_policies(), seeds or [0], speed_profile(args),
                                read.get("closed"), read.get("smoothing_m"), track_limits=track_limits(args),
                                vehicle=args.vehicle, figures_dir=figures, show_progress=True,
                                allow_self_crossing=read.get("allow_self_crossing", False),
                                track_options=read.get("track_options"),
                                on_checked=lambda checked: _report_checked(args, checked), **where)
    if args.track is not None:
        env_id, provenance = env_or_track(args)
        return benchmark_track(env_id, provenance, factories or all_policies(), seeds or [0], vehicle=args.vehicle,
                               figures_dir=figures, show_progress=True, **where)
    return run_benchmark(args.suite, policies=factories, figures_dir=figures, quick=args.quick,
                         seeds=seeds, vehicle=args.vehicle, latency=args.latency, control=args.control,
                         launch=args.launch, numerics=args.numerics, **where)


def run(args: argparse.Namespace) -> int:
    from vtrack_gym.evaluation.api import board_of
    from vtrack_gym.evaluation.storage.store import ResultStore

    _check_track_options(args)
    args.suite = args.suite or "paper"
    seeds = opt.parse_seeds(args.seeds) if args.seeds is not None else None
    names = opt.policy_list(args.policies)
    factories = policy_factories(names, trust_code=args.trust_code, kwargs_text=args.policy_kwargs) \
        if names or args.trust_code or args.policy_kwargs is not None else None  # checked before any work
    check_vehicle(args)
    _check_launch(args, seeds)
    store = ResultStore(args.store)  # verified before any rollout; each row committed as its episode ends
    announce_kernels()
    result = _score(args, factories, seeds, store)
    suite = result["suite"]
    if suite != args.suite and args.track is None and args.tracks is None:
        err(f"suite {suite!r}: not the standard {args.suite} episodes, so stored and ranked apart from the "
            f"{args.suite!r} board (vtrack leaderboard --suite '{suite}')")
    if args.tracks is not None:
        _report_track_set(args, result)
    if result["store_error"] is None:
        err(f"{len(result['rows'])} results stored in {args.store} (suite {suite!r})")
    if result["rows"]:
        board = board_of(result["rows"], suite).entries
        out(render_board(shown_columns(board, args.format, args.columns, suite), args.format), flush=True)
        err(ranking_note(suite))
    for f in result["figures"]:
        err(f"figure: {f}")
    code = report_lost(result["lost"])
    if result["store_error"] is not None:
        raise StoreError(result["store_error"])
    if result.get("refused"):
        err(f"{len(result['refused'])} track file(s) of --tracks refused (listed above); exit status "
            f"{EXIT_TRACKS_REFUSED}")
        return code or EXIT_TRACKS_REFUSED
    return code


def _report_checked(args: argparse.Namespace, checked: Any) -> None:
    """Before any episode: the refused files with their reasons, and one line per track with -v."""
    for file, why in checked.refused:
        err(f"refused: {file}: {why}")
    if getattr(args, "verbose", False):
        for file, line in checked.described:
            err(f"track {file}: {line}")


def _report_track_set(args: argparse.Namespace, result: dict[str, Any]) -> None:
    """The number of track files run and refused, and the suite."""
    err(f"{len(result['tracks'])} track files of --tracks {args.tracks} run ({len(result['refused'])} refused): "
        f"suite {result['suite']!r}")
