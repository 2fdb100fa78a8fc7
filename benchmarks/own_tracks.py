"""Every default baseline on real-circuit-like closed tracks built here (hairpins down to 6 m radius), driven as a
user would: a CSV file with per-station widths, ``vtrack/Track-v0`` with ``curvature_limited(40 km/h, 0.7 g)``.

    PYTHONPATH=. python benchmarks/own_tracks.py [--out DIR] [--policies smc,mpc,...] [--spacing M] [--vehicle NAME]

Reports per track and policy: termination, success (one lap within the road), lap time [s], max |e_y| [m],
RMS |v - v_ref| [m/s], and the peak road-wheel angle as a share of full lock. The circuits are centre-lines made
of straights and arcs (exact tangents), sampled every ``SPACING_M`` (or ``--spacing``) and written without repeating
the start point (real loops end one sample short of the start). ``--vehicle`` drives a car of the catalogue
(``vtrack_gym.vehicle.catalog.list_vehicles()``) or a vehicle file instead of the paper's car.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

SPACING_M = 2.0
"""Point spacing of the generated CSV files [m]."""
POLICIES = ("smc", "mpc", "lqr", "stanley", "pure_pursuit", "mpc_osqp")


@dataclass(frozen=True)
class Segment:
    """A straight (``radius_m`` = inf) or an arc of ``angle_deg`` (left positive) with radius ``radius_m``."""

    length_m: float = 0.0
    radius_m: float = math.inf
    angle_deg: float = 0.0


def straight(length_m: float) -> Segment:
    return Segment(length_m=length_m)


def arc(radius_m: float, angle_deg: float) -> Segment:
    return Segment(length_m=radius_m * math.radians(abs(angle_deg)), radius_m=radius_m, angle_deg=angle_deg)


def chicane(radius_m: float, angle_deg: float) -> list[Segment]:
    """Left angle, right 2 x angle, left angle: no net heading change or lateral offset."""
    return [arc(radius_m, angle_deg), arc(radius_m, -2.0 * angle_deg), arc(radius_m, angle_deg)]


def trace_segments(segments: list[Segment], spacing_m: float) -> tuple[np.ndarray, np.ndarray, float, float, float]:
    """Points every ``spacing_m`` [m] along the segments from (0, 0) heading east; also the end x, y, heading."""
    x = y = psi = 0.0
    xs, ys = [], []
    carry = 0.0   # distance into the current segment of the next sample [m]
    for seg in segments:
        k = 0.0 if math.isinf(seg.radius_m) else math.copysign(1.0 / seg.radius_m, seg.angle_deg)
        s = carry
        while s < seg.length_m - 1e-9:
            px, py, _ = _advance(x, y, psi, k, s)
            xs.append(px)
            ys.append(py)
            s += spacing_m
        carry = s - seg.length_m
        x, y, psi = _advance(x, y, psi, k, seg.length_m)
    return np.array(xs), np.array(ys), x, y, psi


def _advance(x: float, y: float, psi: float, kappa: float, s: float) -> tuple[float, float, float]:
    if kappa == 0.0:
        return x + s * math.cos(psi), y + s * math.sin(psi), psi
    p = psi + kappa * s
    return x + (math.sin(p) - math.sin(psi)) / kappa, y - (math.cos(p) - math.cos(psi)) / kappa, p


def closed_circuit(features_east: list[Segment], features_north: list[Segment], corners_m: tuple[float, ...]
                   ) -> list[Segment]:
    """A counter-clockwise loop: east features, corner, north features, corner, west straight, corner, south
    straight, corner; the west and south straights are solved so that the loop closes exactly."""
    r1, r2, r3, r4 = corners_m
    head = [*features_east, arc(r1, 90.0), *features_north, arc(r2, 90.0)]
    _, _, x, y, _ = trace_segments([*head, arc(r3, 90.0), arc(r4, 90.0)], 1e9)
    west, south = x, y          # what the two straights must take back
    if west < 10.0 or south < 10.0:
        raise ValueError(f"circuit does not close with straights >= 10 m (west {west:.1f}, south {south:.1f})")
    return [*head, straight(west), arc(r3, 90.0), straight(south), arc(r4, 90.0)]


def circuits() -> dict[str, list[Segment]]:
    """Four real-circuit-like loops (radii in m): a hairpin pair, a twisty club circuit, a fast one with a 6 m
    hairpin at the end of the long straight, and a kart-like one (6 m chicane, a 6 m hairpin between 8 m corners,
    a 10-6-10 m S-bend)."""
    return {
        "hairpins": closed_circuit(
            [straight(120.0), *chicane(15.0, 35.0), straight(60.0)],
            [straight(40.0), arc(6.0, 180.0), straight(25.0), arc(7.0, -180.0), straight(40.0)],
            (25.0, 12.0, 20.0, 9.0)),
        "club": closed_circuit(
            [straight(80.0), arc(12.0, 60.0), arc(10.0, -60.0), straight(50.0), *chicane(8.0, 45.0), straight(40.0)],
            [straight(60.0), arc(6.0, -90.0), arc(6.0, 90.0), straight(30.0), *chicane(20.0, 30.0), straight(30.0)],
            (15.0, 30.0, 8.0, 18.0)),
        "fast": closed_circuit(
            [straight(300.0), arc(60.0, 20.0), arc(60.0, -20.0), straight(100.0)],
            [straight(150.0), arc(6.0, 180.0), straight(20.0), arc(6.0, -180.0), straight(100.0)],
            (40.0, 25.0, 50.0, 10.0)),
        "kart": closed_circuit(
            [straight(50.0), *chicane(6.0, 50.0), straight(25.0), arc(8.0, 90.0), arc(6.0, -180.0), arc(8.0, 90.0),
             straight(30.0)],
            [straight(40.0), arc(10.0, -45.0), arc(6.0, 90.0), arc(10.0, -45.0), straight(30.0)],
            (12.0, 6.0, 15.0, 8.0)),
    }


def write_circuit_csv(file: Path, segments: list[Segment], spacing_m: float = SPACING_M,
                      right_m: float = 4.0, left_m: float = 4.5) -> Path:
    """The loop's centre-line as ``# x_m, y_m, w_tr_right_m, w_tr_left_m`` (one sample short of the start)."""
    x, y, x_end, y_end, _ = trace_segments(segments, spacing_m)
    if math.hypot(x_end, y_end) > 1e-6:
        raise ValueError(f"segments do not close (end at {x_end:.3g}, {y_end:.3g})")
    rows = np.column_stack([x, y, np.full(x.size, right_m), np.full(x.size, left_m)])
    np.savetxt(file, rows, fmt="%.3f", delimiter=",", header="x_m, y_m, w_tr_right_m, w_tr_left_m")
    return file


def drive(file: Path, policy_name: str, vehicle: str | None = None, max_speed_kmh: float = 40.0,
          max_lateral_g: float = 0.7, profile: str = "curvature") -> dict[str, float | str | bool]:
    """One episode of a default baseline on the track file with the ``profile`` kind of
    ``tracks.speed_limits.speed_profile_from_limits`` (``max_speed_kmh`` [km/h], ``max_lateral_g`` [g]);
    ``vehicle``: a catalogue name or vehicle file (None: the env's default car)."""
    import gymnasium as gym

    import vtrack_gym
    from vtrack_gym.evaluation.rollouts.rollout import rollout
    from vtrack_gym.evaluation.scoring.metrics import evaluate_trace
    from vtrack_gym.tracks.speed_limits import speed_profile_from_limits

    speed_profile = speed_profile_from_limits(profile, max_speed_kmh, max_lateral_g)
    extra = {} if vehicle is None else {"vehicle": vehicle}
    env = gym.make("vtrack/Track-v0", track=str(file), speed_profile=speed_profile, **extra)
    trace = rollout(vtrack_gym.make_policy(policy_name, env), env, seed=0)
    m = evaluate_trace(trace)
    lock = env.unwrapped.design_model.max_road_wheel_angle_rad
    steer_share = float(np.max(np.abs(trace["road_wheel_angle_rad"]))) / lock
    env.close()
    return {"termination": trace.termination, "success": trace.success, "lap_s": m["duration_s"],
            "max_e_y_m": m["max_e_y_m"], "rms_e_v_mps": m["rms_e_v_mps"], "steer_share": steer_share}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="own_tracks", help="directory for the CSV files (default: %(default)s)")
    ap.add_argument("--policies", default=",".join(POLICIES))
    ap.add_argument("--spacing", type=float, default=SPACING_M, help="point spacing of the CSV files [m]")
    ap.add_argument("--vehicle", default=None, help="catalogue vehicle name or vehicle file (default: paper car)")
    args = ap.parse_args(argv)
    if not (0.1 <= args.spacing <= 20.0):
        ap.error(f"--spacing must be in [0.1, 20] m (got {args.spacing})")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    print("| track | policy | termination | success | lap [s] | max abs e_y [m] | rms v-v_ref [m/s] | "
          "peak steer / lock |")
    print("|---|---|---|---|---|---|---|---|")
    for name, segments in circuits().items():
        stem = name if args.spacing == SPACING_M else f"{name}_{args.spacing:g}m"
        file = write_circuit_csv(out / f"{stem}.csv", segments, args.spacing)
        for policy in [p for p in args.policies.split(",") if p]:
            start = time.perf_counter()
            r = drive(file, policy, args.vehicle)
            print(f"| {name} | {policy} | {r['termination']} | {r['success']} | {r['lap_s']:.1f} | "
                  f"{r['max_e_y_m']:.3f} | {r['rms_e_v_mps']:.3f} | {r['steer_share']:.2f} |  "
                  f"({time.perf_counter() - start:.0f} s)")
            sys.stdout.flush()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
