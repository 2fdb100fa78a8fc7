"""Every default baseline on seeded random circuits: kart-like ones (hairpins, S-bends, chicanes down to 6 m radius),
or fast ones that add 15-60 m corners and 60-250 m sweepers after long straights, where 80 km/h matters. A wider
check than the four hand-built loops of ``own_tracks.py``, driven the same way (a CSV file with per-station widths,
``vtrack/Track-v0`` with a speed profile of ``tracks.speed_limits.speed_profile_from_limits``).

    PYTHONPATH=. python benchmarks/random_circuits.py [--circuits N] [--seed S] [--layout kart|fast]
                                                      [--spacing M[,M...]] [--policies smc,mpc,...]
                                                      [--profile envelope|curvature] [--vehicle NAME] [--out DIR]
                                                      [--max-speed-kmh V] [--max-lateral-g G | --lateral-share F]

Each circuit is a counter-clockwise loop (``own_tracks.closed_circuit``) whose east and north sides carry 2-3
random features. Kart layout: features separated by 15-60 m straights: a chicane (6-20 m, 20-60 deg), an S-bend
(arcs of 6-15 m through 30-90 deg and back) or a hairpin pair (6-9 m, 180 deg each way with a 25-40 m straight
between); corners of 6-30 m. Fast layout: 60-200 m straights, then a hairpin pair of 6-15 m, a corner pair
(15-60 m through 60-150 deg and back), a sweeper pair (60-250 m through 15-45 deg and back), a chicane or an
S-bend; corners of 6-30 m or 30-150 m. Loops that do not close, or whose roads cross or touch (``roads_apart``),
are drawn again. ``--lateral-share 0.93`` sets the profile's lateral limit to 93 % of the driven car's own
steady-state limit up to ``--max-speed-kmh`` (``vehicle.steady_state.lowest_lateral_limit_mps2``). Prints one line
per circuit and spacing (a failed lap with its termination), then per policy: laps completed within the road, and
the median and largest max|e_y| [m] over the laps.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import own_tracks
from own_tracks import Segment, arc, chicane, closed_circuit, straight


def _s_bend(rng: np.random.Generator, side: float) -> list[Segment]:
    """Arcs of 6-15 m through 30-90 deg, twice that back, and the first angle again."""
    angle = side * float(rng.uniform(30.0, 90.0))
    r1, r2, r3 = (float(r) for r in rng.uniform(6.0, 15.0, 3))
    return [arc(r1, angle), arc(r2, -2.0 * angle), arc(r3, angle)]


def random_feature(rng: np.random.Generator) -> list[Segment]:
    """One feature with no net heading change: a chicane, an S-bend or a hairpin pair."""
    kind = rng.integers(3)
    side = 1.0 if rng.random() < 0.5 else -1.0
    if kind == 0:
        return chicane(float(rng.uniform(6.0, 20.0)), side * float(rng.uniform(20.0, 60.0)))
    if kind == 1:
        return _s_bend(rng, side)
    return [arc(float(rng.uniform(6.0, 9.0)), side * 180.0), straight(float(rng.uniform(25.0, 40.0))),
            arc(float(rng.uniform(6.0, 9.0)), -side * 180.0)]


def random_side(rng: np.random.Generator) -> list[Segment]:
    """2-3 features, each after a 15-60 m straight, and a closing 15-60 m straight."""
    segments: list[Segment] = []
    for _ in range(int(rng.integers(2, 4))):
        segments += [straight(float(rng.uniform(15.0, 60.0))), *random_feature(rng)]
    return [*segments, straight(float(rng.uniform(15.0, 60.0)))]


def fast_feature(rng: np.random.Generator) -> list[Segment]:
    """One feature of a fast circuit, no net heading change: a hairpin pair (6-15 m, 180 deg each way, a 25-60 m
    straight between), a fast sweeper pair (R 60-250 m through 15-45 deg and back, 0-60 m apart), a corner pair
    (R 15-60 m through 60-150 deg and back, 30-100 m apart), a chicane (6-20 m, 20-60 deg) or an S-bend (6-15 m
    arcs through 30-90 deg and back)."""
    kind = rng.integers(5)
    side = 1.0 if rng.random() < 0.5 else -1.0
    if kind == 0:
        return [arc(float(rng.uniform(6.0, 15.0)), side * 180.0), straight(float(rng.uniform(25.0, 60.0))),
                arc(float(rng.uniform(6.0, 15.0)), -side * 180.0)]
    if kind == 4:
        angle = side * float(rng.uniform(60.0, 150.0))
        return [arc(float(rng.uniform(15.0, 60.0)), angle), straight(float(rng.uniform(30.0, 100.0))),
                arc(float(rng.uniform(15.0, 60.0)), -angle)]
    if kind == 1:
        angle = side * float(rng.uniform(15.0, 45.0))
        return [arc(float(rng.uniform(60.0, 250.0)), angle), straight(float(rng.uniform(0.0, 60.0))),
                arc(float(rng.uniform(60.0, 250.0)), -angle)]
    if kind == 2:
        return chicane(float(rng.uniform(6.0, 20.0)), side * float(rng.uniform(20.0, 60.0)))
    return _s_bend(rng, side)


def fast_side(rng: np.random.Generator) -> list[Segment]:
    """2-3 fast-circuit features, each after a 60-200 m straight (long enough to reach 80 km/h out of a 6 m
    hairpin at 2 m/s^2), and a closing 60-200 m straight."""
    segments: list[Segment] = []
    for _ in range(int(rng.integers(2, 4))):
        segments += [straight(float(rng.uniform(60.0, 200.0))), *fast_feature(rng)]
    return [*segments, straight(float(rng.uniform(60.0, 200.0)))]


LAYOUTS = ("kart", "fast")
"""kart: features of 6-30 m after 15-60 m straights; fast: hairpins of 6-15 m, corners of 15-60 m and sweepers of
60-250 m too, after 60-200 m straights, the loop's corners of 6-30 m or 30-150 m."""


MIN_GAP_M = 12.0
"""Smallest distance [m] between two parts of a centre-line more than ``GAP_ARC_M`` apart along it (the roads are
8.5 m wide, a 6 m hairpin's two legs 12 m apart)."""
GAP_ARC_M = 30.0


def roads_apart(x: np.ndarray, y: np.ndarray, spacing_m: float) -> bool:
    """True if no two samples more than ``GAP_ARC_M`` apart along the loop are closer than ``MIN_GAP_M``."""
    n = x.size
    d = np.hypot(x[:, None] - x[None, :], y[:, None] - y[None, :])
    k = np.arange(n)
    along = np.abs(k[:, None] - k[None, :])
    along = np.minimum(along, n - along) * spacing_m
    return not bool(np.any((along > GAP_ARC_M) & (d < MIN_GAP_M - 1e-6)))


def _corners(rng: np.random.Generator, layout: str) -> tuple[float, ...]:
    """The four 90 deg corners' radii [m]: 6-30 m; on a fast layout each one of 30-150 m at even odds."""
    tight = rng.uniform(6.0, 30.0, 4)
    if layout == "kart":
        return tuple(float(r) for r in tight)
    fast = rng.uniform(30.0, 150.0, 4)
    return tuple(float(f if rng.random() < 0.5 else t) for t, f in zip(tight, fast, strict=True))


def random_circuit(rng: np.random.Generator, spacing_m: float = 2.0, attempts: int = 500,
                   layout: str = "kart") -> list[Segment]:
    """A random closed loop of ``layout`` (``LAYOUTS``) whose roads neither cross nor touch (``roads_apart``;
    ``ValueError`` after ``attempts``), checked on the centre-line sampled every ``spacing_m`` [m]."""
    if layout not in LAYOUTS:
        raise ValueError(f"layout must be one of {', '.join(LAYOUTS)} (got {layout!r})")
    side = random_side if layout == "kart" else fast_side
    for _ in range(attempts):
        corners = _corners(rng, layout)
        try:
            segments = closed_circuit(side(rng), side(rng), corners)
        except ValueError:
            continue
        x, y, *_ = own_tracks.trace_segments(segments, spacing_m)
        if roads_apart(x, y, spacing_m):
            return segments
    raise ValueError(f"no non-crossing random circuit in {attempts} attempts")


def lateral_limit_g(args: argparse.Namespace) -> float:
    """The profile's lateral limit [g]: ``--max-lateral-g``, or ``--lateral-share`` x the driven car's own
    steady-state limit up to ``--max-speed-kmh`` (``vehicle.steady_state.lowest_lateral_limit_mps2``)."""
    if args.lateral_share is None:
        return 0.7 if args.max_lateral_g is None else args.max_lateral_g
    from vtrack_gym.vehicle.catalog import load_vehicle
    from vtrack_gym.vehicle.params import GRAVITY_MPS2, VehicleParams
    from vtrack_gym.vehicle.steady_state import lowest_lateral_limit_mps2

    car = VehicleParams() if args.vehicle is None else load_vehicle(args.vehicle)
    return args.lateral_share * lowest_lateral_limit_mps2(car, args.max_speed_kmh / 3.6) / GRAVITY_MPS2


def parse(argv: list[str] | None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--circuits", type=int, default=12, help="number of random circuits (default: %(default)s)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the circuit generator (default: %(default)s)")
    ap.add_argument("--layout", choices=LAYOUTS, default="kart", help="kind of circuit (default: %(default)s)")
    ap.add_argument("--spacing", default="1,2", help="point spacings of the CSV files [m] (default: %(default)s)")
    ap.add_argument("--policies", default=",".join(own_tracks.POLICIES))
    ap.add_argument("--profile", choices=("envelope", "curvature"), default="envelope",
                    help="speed profile: inside the friction ellipse, or each axis apart (default: %(default)s)")
    ap.add_argument("--max-speed-kmh", type=float, default=40.0, help="profile's top speed (default: %(default)s)")
    limit = ap.add_mutually_exclusive_group()
    limit.add_argument("--max-lateral-g", type=float, default=None, help="profile's lateral limit (default: 0.7)")
    limit.add_argument("--lateral-share", type=float, default=None,
                       help="lateral limit as a share of the car's own steady-state limit, e.g. 0.93")
    ap.add_argument("--vehicle", default=None, help="catalogue vehicle name or vehicle file (default: paper car)")
    ap.add_argument("--out", default="random_circuits", help="directory for the CSV files (default: %(default)s)")
    args = ap.parse_args(argv)
    if not 1 <= args.circuits <= 1000:
        ap.error(f"--circuits must be in [1, 1000] (got {args.circuits})")
    if not 5.0 <= args.max_speed_kmh <= 160.0:
        ap.error(f"--max-speed-kmh must be in [5, 160] (got {args.max_speed_kmh})")
    if args.max_lateral_g is not None and not 0.1 <= args.max_lateral_g <= 1.5:
        ap.error(f"--max-lateral-g must be in [0.1, 1.5] (got {args.max_lateral_g})")
    if args.lateral_share is not None and not 0.1 <= args.lateral_share <= 1.0:
        ap.error(f"--lateral-share must be in [0.1, 1] (got {args.lateral_share})")
    args.spacings = [float(s) for s in args.spacing.split(",") if s]
    if not args.spacings or any(not 0.1 <= s <= 20.0 for s in args.spacings):
        ap.error(f"--spacing values must be in [0.1, 20] m (got {args.spacing})")
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse(argv)
    lateral_g = lateral_limit_g(args)
    policies = [p for p in args.policies.split(",") if p]
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(args.seed)
    worst: dict[str, list[float]] = {p: [] for p in policies}
    laps: dict[str, int] = {p: 0 for p in policies}
    start = time.perf_counter()
    for c in range(args.circuits):
        segments = random_circuit(rng, layout=args.layout)
        for spacing in args.spacings:
            file = own_tracks.write_circuit_csv(out / f"circuit{c:03d}_{spacing:g}m.csv", segments, spacing)
            cells = []
            for policy in policies:
                r = own_tracks.drive(file, policy, args.vehicle, args.max_speed_kmh, lateral_g, args.profile)
                laps[policy] += bool(r["success"])
                worst[policy].append(float(r["max_e_y_m"]))
                cells.append(f"{policy} {r['max_e_y_m']:.2f}{'' if r['success'] else ' ' + str(r['termination'])}")
            print(f"circuit {c:3d} at {spacing:g} m: " + ", ".join(cells), flush=True)
    print(f"\n{args.circuits} {args.layout} circuits x {len(args.spacings)} spacings, seed {args.seed}, "
          f"vehicle {args.vehicle or 'paper car'}, {args.profile} profile ({args.max_speed_kmh:g} km/h, "
          f"{lateral_g:.4g} g) ({time.perf_counter() - start:.0f} s)\n")
    print("| policy | laps within the road | median max abs e_y [m] | largest max abs e_y [m] |")
    print("|---|---|---|---|")
    n = args.circuits * len(args.spacings)
    for policy in policies:
        e = np.array(worst[policy])
        print(f"| {policy} | {laps[policy]} of {n} | {np.median(e):.2f} | {np.max(e):.2f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
