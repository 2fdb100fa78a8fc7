"""``vtrack lap-bound``: the car's physical lap-time bound on a track, along its minimum-curvature racing line and
its centre line (``vtrack_gym.tracks.lap_time_bound``), with the lap figure on request."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from vtrack_gym.cli import _options as opt
from vtrack_gym.cli._envs import check_vehicle, track_read
from vtrack_gym.cli._terminal import err, out

NAME = "lap-bound"
DIGITS = {"lap_time_s": 3, "length_m": 1, "solve_time_s": 2}
"""Decimals of the Markdown table's columns (2 for the others)."""


def register(sub: Any) -> None:
    from vtrack_gym._ranges import range_of
    from vtrack_gym.envs.track_sources import MAX_TRACK_SMOOTHING_M
    from vtrack_gym.tracks.lap_time import LINES
    from vtrack_gym.tracks.raceline import RacingLineSpec

    p = sub.add_parser(NAME, help="the car's physical lap-time bound on a track (racing line and centre line)",
                       description="Solve the track's minimum-curvature racing line (inside its widths less the "
                       "car's half width and --margin-m) and the quasi-steady-state speed profile at the car's own "
                       "g-g-v limits (steady-state grip, powertrain, brakes, top speed) along it and along the centre "
                       "line; print each line's lap time.")
    p.add_argument("--track", required=True, metavar="NAME|FILE",
                   help="a built-in track name (e.g. handling_course) or a track file: a CSV of points with widths "
                   "(x_m, y_m, w_tr_right_m, w_tr_left_m) or a map (.xodr, .osm, .xml, .gpx)")
    p.add_argument("--track-closed", choices=("auto", "yes", "no"), default="auto",
                   help="--track file: read it as a closed loop (yes), an open road (no) or decide from the end gap "
                   "(auto) (default: auto)")
    p.add_argument("--track-smoothing-m", type=opt.float_in(0.0, MAX_TRACK_SMOOTHING_M), default=None,
                   metavar="M", help="--track file: RMS deviation [m] the spline fit may make from the points "
                   f"(0 interpolates; at most {MAX_TRACK_SMOOTHING_M:g} m) (default: chosen from the coordinates' "
                   "rounding)")
    opt.add_track_reading(p)
    opt.add_vehicle(p)
    p.add_argument("--line", choices=LINES, default=None,
                   help="the line to bound: raceline (the minimum-curvature line) or centreline (default: both)")
    margin, step = range_of(RacingLineSpec, "margin_m"), range_of(RacingLineSpec, "step_m")
    p.add_argument("--margin-m", type=opt.float_in(margin.ge, margin.le), default=0.2, metavar="M",
                   help=f"racing line: clearance [m] between the body side and the track edge, {margin.ge:g} to "
                   f"{margin.le:g} (default: 0.2)")
    p.add_argument("--step-m", type=opt.float_in(step.ge, step.le), default=1.0, metavar="M",
                   help=f"racing line: spacing [m] of the optimisation nodes, {step.ge:g} to {step.le:g} "
                   "(default: 1)")
    p.add_argument("--plot", type=Path, default=None, metavar="FILE.png",
                   help="also write the lap figure: the racing line over the track coloured by speed, the speed "
                   "along each line and the g-g usage (default: no figure)")
    p.add_argument("--format", choices=("md", "json"), default="md",
                   help="md: a table row per line; json: every figure of each line (default: md)")


def needed_modules(args: argparse.Namespace) -> list[str]:
    return ["matplotlib"] if args.plot is not None else []


def check_outputs(args: argparse.Namespace) -> None:
    if args.plot is not None:
        from vtrack_gym._io import check_output_file

        check_output_file(args.plot, "--plot")


def _track(args: argparse.Namespace) -> Any:
    """The track of --track: a built-in name, or a file read as the reading options say."""
    from vtrack_gym.tracks import load_track, track_names

    read = track_read(args)
    if args.track in track_names():
        if read:
            raise ValueError(f"--track {args.track} is a built-in track; the file-reading options apply to files")
        return load_track(args.track)
    options = dict(read.pop("track_options", None) or {})
    return load_track(args.track, **read, **options)


def row(bound: Any, track: Any, vehicle: str) -> dict[str, Any]:
    """One result row of a lap-time bound."""
    length = bound.path.length_m
    return {"track": track.name, "vehicle": vehicle, "line": bound.line, "lap_time_s": round(bound.lap_time_s, 3),
            "mean_speed_kmh": round(3.6 * length / bound.lap_time_s, 2),
            "top_speed_kmh": round(3.6 * bound.top_speed_reached_mps, 2), "length_m": round(length, 2),
            "solve_time_s": round(bound.solve_time_s, 3)}


def run(args: argparse.Namespace) -> int:
    from vtrack_gym.evaluation.leaderboard.report_formats import to_markdown
    from vtrack_gym.tracks import gg_limits, lap_time_bound

    check_vehicle(args)
    track = _track(args)
    limits = gg_limits(args.vehicle)
    lines = [args.line] if args.line else ["centreline", "raceline"]
    bounds = [lap_time_bound(track, args.vehicle, line, margin_m=args.margin_m, step_m=args.step_m,
                             limits=limits) for line in lines]
    rows = [row(b, track, limits.name) for b in bounds]
    if args.format == "json":
        out(json.dumps(rows, indent=2))
    else:
        out(to_markdown([{k: f"{v:.{DIGITS.get(k, 2)}f}" if isinstance(v, float) else v for k, v in r.items()}
                         for r in rows]))
    if len(bounds) == 2:
        gain = 100.0 * (1.0 - bounds[1].lap_time_s / bounds[0].lap_time_s)
        err(f"{track.name}: the racing line is {gain:.2f} % faster than the centre line")
    if args.plot is not None:
        from vtrack_gym.evaluation.figures.lap_figure import write_lap_figure

        err(f"figure: {write_lap_figure(track, bounds[::-1], args.plot)}")
    return 0
