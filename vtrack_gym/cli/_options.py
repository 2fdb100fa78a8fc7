"""Options and argument types several ``vtrack`` commands share (parsing only; checks live in the library)."""

from __future__ import annotations

import argparse
import re
from pathlib import Path
from typing import Any

from vtrack_gym.cli._terminal import write_safe
from vtrack_gym.evaluation.storage.store import DEFAULT_STORE_PATH
from vtrack_gym.evaluation.storage.store import MAX_SEED as MAX_STORED_SEED

DEFAULT_RESULTS_DIR = Path("vtrack_results")
DEFAULT_FIGURES_DIR = DEFAULT_RESULTS_DIR / "figures"
DEFAULT_PLOTS_DIR = DEFAULT_RESULTS_DIR / "plots"
MAX_RNG_SEED = 2**32 - 1
"""Largest ``--seed`` of ``train`` and ``tune`` (numpy's legacy seeding, used by SB3 and pymoo, takes 32 bits)."""
MAX_WORKERS = 4096
"""Largest ``--workers`` (local processes or Ray tasks in flight); a pool starts no more than it has episodes."""
MIN_LATERAL_G = 0.01
"""Smallest ``--max-lateral-g`` the CLI takes [g] (the library takes any positive limit)."""
MAX_SEED = MAX_STORED_SEED
"""Largest episode ``--seed`` (the largest seed a store row holds)."""

_INTEGER = re.compile(r"[+-]?[0-9]+")


class Parser(argparse.ArgumentParser):
    """``argparse.ArgumentParser`` that refuses ``--opt=--`` (argparse drops the ``--`` and hands the option an
    empty list instead of a value: ``vtrack tune --generations=--`` gave ``generations = []``) and escapes what it
    prints (an option value echoed in an error may hold terminal control characters). Options are never
    abbreviated (``--policy`` is not ``--policy-kwargs``): ``allow_abbrev`` is off for every command."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs["allow_abbrev"] = False
        super().__init__(*args, **kwargs)

    def _get_values(self, action: argparse.Action, arg_strings: list[str]) -> Any:
        if action.option_strings and action.nargs is None and arg_strings == ["--"]:
            self.error(f"argument {'/'.join(action.option_strings)}: expected one value, got '--'")
        return super()._get_values(action, arg_strings)

    def _print_message(self, message: str, file: Any = None) -> None:
        if message:
            import sys

            write_safe(message, file or sys.stderr)


def int_in(low: int, high: int):
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


def float_in(low: float, high: float):
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


def add_store(p: argparse.ArgumentParser) -> None:
    p.add_argument("--store", type=Path, default=DEFAULT_STORE_PATH,
                   help=f"SQLite leaderboard file (created if missing; default: {DEFAULT_STORE_PATH})")


def add_format(p: argparse.ArgumentParser, reports: bool = False) -> None:
    """``--format``: the registered output formats (``evaluation.leaderboard.output_formats``; ``reports``: with the
    report-only ones, latex and html)."""
    from vtrack_gym.evaluation.leaderboard.output_formats import format_names, formats_help

    choices = format_names(reports)
    p.add_argument("--format", choices=choices, default="md",
                   help=f"how to print the leaderboard: {formats_help(choices)} (default: md)")


def policy_help() -> str:
    """What a ``--policy`` value may be, the names read from the policy registry and the shipped agents' folder."""
    from vtrack_gym.baselines.registry import available_policies, pedal_policies, race_policies
    from vtrack_gym.baselines.shipped import shipped_agents

    return (f"a baseline name ({', '.join(available_policies())}; on the race ids also "
            f"{', '.join(race_policies())}; with --control steer_accel also {', '.join(pedal_policies())}), "
            "NAME:PRESET (smc:paper), a shipped agent name "
            f"({', '.join(shipped_agents())}), a weights-only agent file (agent.json / agent.npz), or, with "
            "--trust-code, MODULE:NAME of your own policy (a class: NAME.from_env(env) if it defines from_env, else "
            "NAME(); keyword arguments from --policy-kwargs)")


def add_columns(p: argparse.ArgumentParser) -> None:
    """``--columns key|all``: the columns of the trimmed formats (the others carry them all)."""
    from vtrack_gym.evaluation.leaderboard.board_view import COLUMN_SETS
    from vtrack_gym.evaluation.leaderboard.output_formats import format_names, get_format

    trimmed = [n for n in format_names() if get_format(n).trimmed]
    others = [n for n in format_names() if not get_format(n).trimmed]
    p.add_argument("--columns", choices=COLUMN_SETS, default="key",
                   help=f"{', '.join(trimmed)}: key (env, policy, rank, success rate, max and RMS e_y, the suite's "
                   f"primary metric with its interval, failure reasons) or all (every column); {', '.join(others)} "
                   "always carry all columns (default: key)")


def add_vehicle(p: argparse.ArgumentParser) -> None:
    """``--vehicle NAME|FILE``: the car (a shipped vehicle or a vehicle JSON file; default the paper's car)."""
    from vtrack_gym.vehicle.catalog import list_vehicles

    p.add_argument("--vehicle", default=None, metavar="NAME|FILE",
                   help=f"the car: {', '.join(list_vehicles())} or a vehicle .json file (default: the paper's "
                   "hatchback); recorded in the rows' options, so cars are ranked apart")


def latency_value(text: str) -> str | float:
    """``--latency``'s value: ``measured`` or a number of seconds in [0, 1] (``argparse.ArgumentTypeError``
    otherwise)."""
    from vtrack_gym.envs.latency import Latency

    try:
        chosen = Latency.parse(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc).replace("latency must", "--latency must")) from None
    return chosen.seconds if chosen.mode == "fixed" else chosen.mode


def add_latency(p: argparse.ArgumentParser) -> None:
    """``--latency measured|SECONDS``: charge each decision's compute in the loop (``envs.latency``)."""
    p.add_argument("--latency", default=None, type=latency_value, metavar="measured|SECONDS",
                   help="charge each decision's compute in the loop: 'measured' (the policy call's time) or a "
                   "fixed budget in seconds; each command takes effect that long after its observation (rounded up "
                   "to the physics step); rows record it and rank apart from the ideal ones (default: off)")


def add_control(p: argparse.ArgumentParser, what: str = "rows record it and rank apart from the steer rows") -> None:
    """``--control MODE``: what the action drives (``envs.control``)."""
    from vtrack_gym.envs.control import CONTROL_MODES

    p.add_argument("--control", choices=tuple(CONTROL_MODES), default=None,
                   help="what the action drives: steer (steering; the PD-FLC holds the speed), steer_accel "
                   "(steering and a longitudinal demand, throttle/brake) or steer_rate_accel (steering rate and the "
                   "demand); the steering baselines drive the longitudinal modes with a speed law built on the "
                   f"PD-FLC; {what} (default: steer)")


def add_numerics(p: argparse.ArgumentParser) -> None:
    """``--numerics default|fast``: which compiled plant integrates the cars (``vehicle.numerics``)."""
    from vtrack_gym.vehicle.numerics import NUMERICS

    p.add_argument("--numerics", choices=tuple(NUMERICS), default=None,
                   help="which compiled plant integrates the cars: default (the pinned kernel) or fast (the SIMD "
                   "kernel, several times faster on many cars, within the tolerances the performance docs state); "
                   "rows record fast and rank apart from the default rows (default: default)")


def add_launch(p: argparse.ArgumentParser) -> None:
    """``--launch step|powertrain``: how the reference of a held speed from rest leaves the start (``envs.launch``)."""
    from vtrack_gym.envs.launch import LAUNCHES

    p.add_argument("--launch", choices=tuple(LAUNCHES), default=None,
                   help="with a longitudinal --control: how a held speed from rest (LateralTracking-v0) starts: step "
                   "(the set speed from t = 0, the id's own) or powertrain (a ramp at 0.75 of the car's full-throttle "
                   "acceleration); vtrack benchmark gives it to the suite's episodes that hold a speed from rest "
                   "and runs the others as they are; rows record it (default: step)")


def add_user_code(p: argparse.ArgumentParser) -> None:
    """``--trust-code`` and ``--policy-kwargs``: policies of the user's own code (``MODULE:NAME``)."""
    p.add_argument("--trust-code", action="store_true",
                   help="allow a policy MODULE:NAME of your own code: imports and runs that Python module (the "
                   "working directory is on the import path); a class is built as NAME.from_env(env) if it defines "
                   "from_env, else NAME()")
    p.add_argument("--policy-kwargs", default=None, metavar="JSON",
                   help="keyword arguments for a MODULE:NAME policy, a JSON object, e.g. '{\"k_y\": 0.2}' "
                   "(default: none)")


def add_track(p: argparse.ArgumentParser, text: str | None = None, where: Any = None) -> None:
    """``--track FILE`` (in the group ``where`` if given, e.g. exclusive with --env), how it is read and its
    speed-profile options."""
    from vtrack_gym.envs.criteria import TRACK_LIMIT_RULES
    from vtrack_gym.envs.track_sources import MAX_TRACK_SMOOTHING_M
    from vtrack_gym.tracks.speed_limits import (
        DEFAULT_MAX_LATERAL_G,
        DEFAULT_MAX_SPEED_KMH,
        DEFAULT_PROFILE_KIND,
        MAX_LATERAL_G,
        MAX_SPEED_KMH,
        MIN_SPEED_KMH,
        PROFILE_KINDS,
    )

    (where if where is not None else p).add_argument("--track", type=Path, default=None, metavar="FILE",
                   help=text or "drive on this track file instead of --env: a CSV of points (columns by header: "
                   "x_m, y_m, optional z_m, w_tr_right_m, w_tr_left_m, v_mps) or a map (.xodr OpenDRIVE, .osm "
                   "Lanelet2, .xml CommonRoad, .gpx GPX; vtrack/Track-v0)")
    p.add_argument("--track-closed", choices=("auto", "yes", "no"), default="auto",
                   help="--track: read the file as a closed loop (yes), an open road (no) or decide from the end gap "
                   "against the point spacing (auto; the decision is printed) (default: auto)")
    p.add_argument("--track-smoothing-m", type=float_in(0.0, MAX_TRACK_SMOOTHING_M), default=None, metavar="M",
                   help="--track: RMS deviation [m] the spline fit may make from the file's points, for noisy "
                   f"coordinates (e.g. GPS; 0 interpolates; at most {MAX_TRACK_SMOOTHING_M:g} m) (default: chosen "
                   "from the coordinates' rounding; a map's noise estimate; 0 for OpenDRIVE's exact geometry)")
    p.add_argument("--track-limits", choices=TRACK_LIMIT_RULES, default=None,
                   help="--track: the track-limit rule a run is judged by: wheels (off the track when all four wheel "
                   "contact points are beyond an edge; each excursion counted), body (no part of the body beyond an "
                   "edge) or centre (the CG, judged exactly); recorded with every row (default: none given, "
                   "vtrack/Track-v0's own rule: the episode ends off_road when the CG passes an edge)")
    add_track_reading(p)
    p.add_argument("--speed-profile", choices=PROFILE_KINDS, default=DEFAULT_PROFILE_KIND,
                   help="--track: target speed: envelope (the fastest profile within --max-speed-kmh and "
                   "--max-lateral-g with lateral and longitudinal acceleration combined inside a friction ellipse, "
                   "2 m/s^2 up, 3 m/s^2 down), curvature (the same limits each axis apart: corner entries may "
                   "combine full braking with full lateral acceleration), constant (--max-speed-kmh) or file (the "
                   "v_mps column; takes neither option) (default: envelope)")
    p.add_argument("--max-speed-kmh", type=float_in(MIN_SPEED_KMH, MAX_SPEED_KMH), default=None,
                   help=f"--track with --speed-profile envelope, curvature or constant: maximum speed [km/h], "
                   f"{MIN_SPEED_KMH:g} to {MAX_SPEED_KMH:g} (default: {DEFAULT_MAX_SPEED_KMH:g})")
    p.add_argument("--max-lateral-g", type=float_in(MIN_LATERAL_G, MAX_LATERAL_G), default=None,
                   help=f"--track with --speed-profile envelope or curvature: lateral acceleration limit [g], "
                   f"{MIN_LATERAL_G:g} to {MAX_LATERAL_G:.2f}, at most the car's own steady-state limit up to "
                   "--max-speed-kmh (0.80 g for the paper's car at "
                   "80 km/h, below mu g; a warning above 90 %% of it) "
                   f"(default: {DEFAULT_MAX_LATERAL_G:g})")


def add_track_reading(p: argparse.ArgumentParser) -> None:
    """How a --track / --tracks file is read besides closure and smoothing: self-crossing, format and a map's route,
    lane and road width (``tracks.formats.TrackRead``)."""
    from vtrack_gym.tracks.formats import FORMATS, MAX_ROAD_WIDTH_M, MIN_ROAD_WIDTH_M

    p.add_argument("--allow-self-crossing", action="store_true",
                   help="--track: accept a centre line that crosses itself (a road over a bridge, a figure eight); "
                   "recorded with the results")
    p.add_argument("--track-format", choices=tuple(FORMATS), default=None,
                   help="--track: the file's format (default: from its suffix: "
                   + ", ".join(f"{'/'.join(f.suffixes)} {n}" for n, f in FORMATS.items()) + "; any other suffix: csv)")
    p.add_argument("--track-route", default=None, metavar="IDS",
                   help="--track map: the road ids (OpenDRIVE) or lanelet ids (Lanelet2, CommonRoad) to drive, in "
                   "order, comma-separated, e.g. 1,2,3; lanelets that do not follow each other are joined by the "
                   "map's routing (default: the map's only road or lanelet; CommonRoad: the planning problem's route)")
    p.add_argument("--track-lane", type=int_in(-100, 100), default=None, metavar="ID",
                   help="--track OpenDRIVE map: drive the middle of this lane, an id in [-100, -1] or [1, 100] (-1: "
                   "the first lane right of the reference line in the direction of travel) (default: the middle of "
                   "the drivable carriageway)")
    p.add_argument("--road-width-m", type=float_in(MIN_ROAD_WIDTH_M, MAX_ROAD_WIDTH_M), default=None, metavar="M",
                   help=f"--track GPX file: the road's full width [m], {MIN_ROAD_WIDTH_M:g} to {MAX_ROAD_WIDTH_M:g} "
                   "(default: 7)")


def policy_list(text: str) -> list[str]:
    """The names of a comma-separated ``--policies`` value (spaces around the names ignored, empty items dropped)."""
    return [p.strip() for p in text.split(",") if p.strip()]


def parse_seeds(text: str) -> list[int]:
    """The seeds of a ``--seeds`` value (``vtrack_gym.evaluation.suite.seeds.parse_seeds``; errors name ``--seeds``)."""
    from vtrack_gym.evaluation.suite.seeds import parse_seeds as parse

    return parse(text, "--seeds")
