"""How closely the PD-FLC speed loop follows the default track profile, per circuit and speed cap.

    PYTHONPATH=. python benchmarks/profile_following.py [--tracks handling_course,FILE.csv,...] [--caps 100,150]
        [--policy pure_pursuit] [--vehicle NAME] [--authority speed_loop|FRACTION|none]

Each run is one lap of ``vtrack/Track-v0`` (from rest) with the profile ``vtrack eval --track FILE --max-speed-kmh
CAP`` drives (``speed_profile_from_limits("envelope", CAP)``: the friction ellipse within 0.7 g, speeding up as the
car's powertrain allows at the throttle its speed loop holds), the lateral baseline ``--policy`` steering and the
paper's PD-FLC on the pedals. ``--authority none`` drives the profile of earlier versions (a fixed 2 m/s^2, the
cap taken as given) for comparison. Reports per track and cap: termination, the profile's top speed and lap time,
the car's lap time, RMS and max |v - v_ref| [m/s] (``evaluation.scoring.metrics``).

The real circuits are the TUM racetrack database's centre lines (not shipped; ``git clone
https://github.com/TUMFTM/racetrack-database`` and pass ``racetrack-database/tracks/Monza.csv`` ...).
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path


def drive(track: str, cap_kmh: float, policy: str, vehicle: str | None, authority: float | str | None
          ) -> dict[str, object]:
    """One lap of ``policy`` with the PD-FLC on ``track`` (a built-in name or a file) at ``cap_kmh`` [km/h]."""
    import gymnasium as gym
    import numpy as np

    import vtrack_gym
    from vtrack_gym.evaluation.rollouts.rollout import rollout
    from vtrack_gym.evaluation.scoring.metrics import evaluate_trace
    from vtrack_gym.tracks.speed_limits import speed_profile_from_limits
    from vtrack_gym.tracks.time_law import time_law

    profile = speed_profile_from_limits("envelope", cap_kmh, None, throttle_authority=authority)
    extra = {} if vehicle is None else {"vehicle": vehicle}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", UserWarning)
        env = gym.make("vtrack/Track-v0", track=track, speed_profile=profile, **extra)
    table = env.unwrapped.speed_tables[0]
    trace = rollout(vtrack_gym.make_policy(policy, env), env, seed=0)
    m = evaluate_trace(trace)
    env.close()
    return {"termination": trace.termination, "profile_top_kmh": float(np.max(table.v_mps)) * 3.6,
            "profile_lap_s": time_law(table).total_time_s, "lap_s": m["duration_s"],
            "rms_e_v": m["rms_e_v_mps"], "max_e_v": m["max_e_v_mps"],
            "warnings": [str(w.message) for w in caught]}


def authority_value(text: str) -> float | str | None:
    """``--authority``: ``speed_loop``, ``none`` or a throttle fraction in (0, 1]."""
    if text in ("speed_loop", "none"):
        return None if text == "none" else text
    value = float(text)
    if not 0.0 < value <= 1.0:
        raise argparse.ArgumentTypeError(f"--authority must be speed_loop, none or in (0, 1] (got {text})")
    return value


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tracks", default="handling_course", help="comma-separated built-in names or track files")
    ap.add_argument("--caps", default="100,150", help="comma-separated speed caps [km/h]")
    ap.add_argument("--policy", default="pure_pursuit", help="lateral baseline (default: %(default)s)")
    ap.add_argument("--vehicle", default=None, help="catalogue name or vehicle file (default: the paper's car)")
    ap.add_argument("--authority", type=authority_value, default="speed_loop",
                    help="throttle authority the profile assumes: speed_loop (default), none or a fraction")
    args = ap.parse_args(argv)
    caps = [float(c) for c in args.caps.split(",")]
    print("| track | cap [km/h] | termination | profile top [km/h] | profile lap [s] | lap [s] | "
          "RMS e_v [m/s] | max e_v [m/s] |")
    print("|---|---|---|---|---|---|---|---|")
    for track in args.tracks.split(","):
        name = Path(track).stem
        for cap in caps:
            r = drive(track, cap, args.policy, args.vehicle, args.authority)
            print(f"| {name} | {cap:g} | {r['termination']} | {r['profile_top_kmh']:.1f} | {r['profile_lap_s']:.1f} "
                  f"| {r['lap_s']:.1f} | {r['rms_e_v']:.3f} | {r['max_e_v']:.3f} |", flush=True)
            for text in r["warnings"]:
                print(f"  warning: {text}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
