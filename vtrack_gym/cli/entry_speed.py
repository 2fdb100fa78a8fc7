"""``vtrack entry-speed``: the highest entry speed at which each policy passes an ISO 3888 lane change, against the
car's physical bound (``vtrack_gym.evaluation.rollouts.entry_speed.max_entry_speed_kmh``)."""

from __future__ import annotations

import argparse
import json
from typing import Any

from vtrack_gym.cli import _options as opt
from vtrack_gym.cli._envs import announce_kernels, check_vehicle
from vtrack_gym.cli._extras import osqp_for
from vtrack_gym.cli._policies import policy_makers
from vtrack_gym.cli._terminal import err, out

NAME = "entry-speed"
DEFAULT_ENV = "vtrack/ISO3888-2-v1"


def register(sub: Any) -> None:
    from vtrack_gym.evaluation.rollouts.entry_speed import (
        DEFAULT_CHECKS,
        DEFAULT_TOL_KMH,
        ENTRY_SPEED_ENV_IDS,
        MAX_CHECKS,
        MIN_TOL_KMH,
    )

    e = sub.add_parser(NAME, help="search the highest entry speed each policy passes an ISO 3888 lane change at",
                       description="Bisect on pass/fail (the leaderboard's success verdict: no cone gate left, the "
                       "end reached, no spin-out) between --lo-kmh and --hi-kmh and compare the highest passing "
                       "entry speed with the car's physical bound (its planned line within its own grip).")
    e.add_argument("--policy", required=True,
                   help=f"policy name(s), comma-separated, each {opt.policy_help()}")
    opt.add_user_code(e)
    e.add_argument("--env", default=DEFAULT_ENV, choices=ENTRY_SPEED_ENV_IDS,
                   help=f"the manoeuvre (default: {DEFAULT_ENV})")
    opt.add_vehicle(e)
    e.add_argument("--lo-kmh", type=opt.float_in(0.01, 200.0), default=None, metavar="KMH",
                   help="lowest entry speed probed, in (0, 200] km/h (default: half the car's bound)")
    e.add_argument("--hi-kmh", type=opt.float_in(0.01, 200.0), default=None, metavar="KMH",
                   help="highest entry speed probed, in (0, 200] km/h (default: 1.15 x the bound, at most 200)")
    e.add_argument("--tol-kmh", type=opt.float_in(MIN_TOL_KMH, 200.0), default=DEFAULT_TOL_KMH, metavar="KMH",
                   help=f"bisection resolution [km/h], {MIN_TOL_KMH:g} to 200 (default: {DEFAULT_TOL_KMH:g})")
    e.add_argument("--checks", type=opt.int_in(0, MAX_CHECKS), default=DEFAULT_CHECKS, metavar="N",
                   help=f"probes below the speed found that must pass too (monotonicity check; default: "
                   f"{DEFAULT_CHECKS})")
    e.add_argument("--seed", "--episode-seed", dest="seed", type=opt.int_in(0, 2**31 - 1), default=0,
                   help="episode seed: the env's reset seed of every run of the search (default: 0)")
    e.add_argument("--format", choices=("md", "json"), default="md",
                   help="md: one table row per policy (and the probes of a single policy); json: every result "
                   "with its probes (default: md)")


def needed_modules(args: argparse.Namespace) -> list[str]:
    return osqp_for(opt.policy_list(args.policy))


def run(args: argparse.Namespace) -> int:
    from vtrack_gym.evaluation.rollouts.entry_speed import entry_speed_bound, search_range

    names = opt.policy_list(args.policy)
    if not names:
        raise ValueError("--policy needs at least one policy name, e.g. --policy mpc")
    makers = policy_makers(names, "default", args.trust_code, args.policy_kwargs)  # checked before any run
    check_vehicle(args)
    bound = entry_speed_bound(args.env, args.vehicle)
    lo, hi = search_range(bound, args.lo_kmh, args.hi_kmh)
    err(f"{args.env}: physical entry-speed bound {bound:.1f} km/h ({args.vehicle or 'default car'}); search "
        f"{lo:g}-{hi:g} km/h to {args.tol_kmh:g} km/h")
    announce_kernels()
    results = [_search(args, name, make) for name, make in makers]
    if args.format == "json":
        out(json.dumps([r.to_dict() for r in results], indent=2, allow_nan=False))
    else:
        out(_table(results))
        if len(results) == 1:
            out("\n" + _probe_table(results[0]))
    for r in results:
        if r.above_physical_bound:
            err(f"{r.policy_id}: passed above the physical bound of {r.entry_speed_bound_kmh:.1f} km/h: the run "
                "cut through the physics or the judge, look at its trajectory")
        if not r.monotone:
            err(f"{r.policy_id}: a speed below the one found failed: pass/fail is not monotone in the entry speed")
    return 0


def _search(args: argparse.Namespace, name: str, make: Any) -> Any:
    """One policy's search with a progress bar (one tick per run)."""
    from vtrack_gym._progress import progress_bar
    from vtrack_gym.evaluation.rollouts.entry_speed import (
        entry_speed_bound,
        max_entry_speed_kmh,
        planned_probes,
        search_range,
    )

    lo, hi = search_range(entry_speed_bound(args.env, args.vehicle), args.lo_kmh, args.hi_kmh)
    total = planned_probes(lo, hi, args.tol_kmh, args.checks) if lo < hi and args.tol_kmh > 0 else None
    with progress_bar(total=total, desc=f"{name}", unit="run") as bar:
        def tick(probe: Any) -> None:
            bar.set_postfix_str(f"{probe.speed_kmh:.2f} km/h {'pass' if probe.passed else probe.reason}")
            bar.update(1)

        return max_entry_speed_kmh(make, args.env, vehicle=args.vehicle, lo_kmh=args.lo_kmh, hi_kmh=args.hi_kmh,
                                   tol_kmh=args.tol_kmh, checks=args.checks, seed=args.seed, policy_id=name,
                                   on_probe=tick)


def _table(results: list[Any]) -> str:
    from vtrack_gym.evaluation.leaderboard.report_formats import to_markdown

    return to_markdown([{"policy": r.policy_id, "env": r.env_id, "vehicle": r.vehicle or "default",
                         "max_entry_speed_kmh": _speed(r), "entry_speed_bound_kmh": r.entry_speed_bound_kmh,
                         "fraction_of_bound": r.entry_speed_fraction if r.entry_speed_fraction is not None
                         else float("nan"),
                         "above_physical_bound": "yes" if r.above_physical_bound else "no",
                         "monotone": "yes" if r.monotone else "no", "runs": len(r.probes)} for r in results])


def _speed(r: Any) -> Any:
    """The table cell of the speed found: the number, ``< lo`` when nothing passed, ``>= hi`` when capped."""
    if r.max_entry_speed_kmh is None:
        return f"< {r.lo_kmh:g}"
    return f">= {r.hi_kmh:g}" if r.capped else r.max_entry_speed_kmh


def _probe_table(r: Any) -> str:
    from vtrack_gym.evaluation.leaderboard.report_formats import to_markdown

    return to_markdown([{"run": i, "stage": p.stage, "entry_speed_kmh": p.speed_kmh,
                         "result": "pass" if p.passed else p.reason} for i, p in enumerate(r.probes, 1)])
