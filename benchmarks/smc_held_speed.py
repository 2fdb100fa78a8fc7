"""Why the steer mode's smc spins out of DLC120-v0 in ``steer_accel``, and the ``accel`` preset that does not.

Five measurements, seed 0, each one episode of ``DLC120-v0`` (120 km/h double lane change); 1-4 with the steer
mode's default preset (the packaged GA result, ``make_policy("smc", env, preset="tuned")``, which a ``steer`` env's
``make_policy("smc", env)`` builds):

1. the held set speed (reset option ``target_speed_mps``) swept across the speeds the PD-FLC (``steer``) and the
   default speed law (``steer_accel``) drive at: success, max |e_y| [m], mean speed [m/s];
2. the pedals held still (a constant demand, no speed law): whether the speed law's pedal work (the friction
   ellipse of the driven front axle, the body's v_y r feed-forward, braking) is what spins the car;
3. the steering actuator: the share of the lane change's steps at the road-wheel rate limit
   (``SteeringParams.max_road_wheel_rate_radps``) and the largest gap between command and road-wheel angle [rad];
4. the SMC's gains: a smaller reaching gain eta or a wider boundary layer Delta on both paper scenarios, against
   the 25 % margin on the steer mode's max |e_y|;
5. the held set speed swept from 31 to 35 m/s in every control mode for the steer mode's preset and the ``accel``
   preset (the high-speed gains ``make_policy("smc", env)`` builds in the longitudinal modes): completed episodes
   and the largest max |e_y| [m] among them.

CPU (process) and wall seconds of the whole run and the load average are printed.
Run: ``python benchmarks/smc_held_speed.py``.
"""

from __future__ import annotations

import logging
import os
import time
from typing import Any

import gymnasium as gym
import numpy as np

from vtrack_gym.baselines.registry import make_policy

SWEEP_MPS = (32.0, 32.5, 32.7, 32.9, 33.1, 120.0 / 3.6, 33.5, 34.0)
BAND_MPS = tuple(31.0 + 0.25 * i for i in range(17))
"""The speed band of measurement 5: 31 to 35 m/s [m/s] in 0.25 m/s steps."""
CONSTANT_DEMANDS = (0.20, 0.25, 0.30)
GAINS = ({}, {"reaching_gain": 3.0}, {"reaching_gain": 5.0}, {"boundary_layer": 0.6}, {"boundary_layer": 0.8})


def run(env_id: str, control: str, speed: float | None = None, demand: float | None = None,
        preset: str = "tuned", **overrides: Any) -> dict[str, Any]:
    """One episode's verdict, max |e_y| [m], mean speed [m/s], share of steps at the steering rate limit and the
    largest command - road-wheel gap [rad]."""
    env = gym.make(env_id, control=control)
    policy = make_policy("smc", env, preset=preset, **overrides)
    obs, info = env.reset(seed=0, options=None if speed is None else {"target_speed_mps": speed})
    car = env.unwrapped.config.vehicle.steering
    limit = car.max_road_wheel_rate_radps * env.unwrapped.control_period_s
    e_y, v, at_limit, gap, wheel, done = [], [], 0, 0.0, 0.0, False
    while not done:
        action, _ = policy.predict(obs)
        if demand is not None:
            action = np.array([action[0], demand], dtype=np.float32)
        obs, _, terminated, truncated, info = env.step(action)
        done = terminated or truncated
        e_y.append(abs(info["e_y_m"]))
        v.append(info["v_mps"])
        at_limit += abs(info["road_wheel_angle_rad"] - wheel) >= 0.99 * limit
        gap = max(gap, abs(info["steering_command_rad"] - info["road_wheel_angle_rad"]))
        wheel = info["road_wheel_angle_rad"]
    return {"ok": bool(info["success"]), "why": info["termination"], "max_ey": max(e_y),
            "mean_v": float(np.mean(v)), "at_limit": at_limit / len(v), "gap": gap}


def _line(label: str, r: dict[str, Any]) -> str:
    verdict = "completed" if r["ok"] else f"failed ({r['why']})"
    return (f"| {label} | {verdict} | {r['max_ey']:.4f} | {r['mean_v']:.2f} | {100 * r['at_limit']:.1f} % | "
            f"{r['gap']:.3f} |")


def band(preset: str, control: str) -> str:
    """Measurement 5's row: completed episodes of the band and the largest max |e_y| [m] among them."""
    runs = [run("DLC120-v0", control, speed, preset=preset) for speed in BAND_MPS]
    done = [r["max_ey"] for r in runs if r["ok"]]
    marks = "".join("Y" if r["ok"] else "." for r in runs)
    worst = f"{max(done):.4f}" if done else "-"
    return f"| {preset} | {control} | {len(done)} / {len(runs)} | {worst} | `{marks}` |"


def main() -> None:
    logging.disable(logging.WARNING)     # the SMC's boundary-layer notice, once per policy built
    c0, w0 = time.process_time(), time.perf_counter()
    print(f"load average at start: {os.getloadavg()}\n")
    print("| DLC120-v0, seed 0 | verdict | max abs e_y [m] | mean speed [m/s] | steps at the rate limit | "
          "largest command - wheel gap [rad] |\n|---|---|---|---|---|---|")
    for control in ("steer", "steer_accel"):
        for speed in SWEEP_MPS:
            print(_line(f"{control}, set speed {speed:.2f} m/s", run("DLC120-v0", control, speed)), flush=True)
    for demand in CONSTANT_DEMANDS:
        print(_line(f"steer_accel, constant demand {demand:.2f}", run("DLC120-v0", "steer_accel", demand=demand)))
    print("\n| gains (steer_accel) | DLC120-v0 | LateralTracking-v0 |\n|---|---|---|")
    for overrides in GAINS:
        cells = []
        for env_id in ("DLC120-v0", "LateralTracking-v0"):
            r = run(env_id, "steer_accel", **overrides)
            cells.append(f"{r['max_ey']:.4f} / {'yes' if r['ok'] else 'no (' + r['why'] + ')'}")
        label = ", ".join(f"{k} {v}" for k, v in overrides.items()) or "steer mode's preset"
        print(f"| {label} | {cells[0]} | {cells[1]} |", flush=True)
    print("\n| DLC120-v0, set speed 31 to 35 m/s | mode | completed | largest max abs e_y [m] | per speed |\n"
          "|---|---|---|---|---|")
    for preset in ("tuned", "accel"):
        for control in ("steer", "steer_accel", "steer_rate_accel"):
            print(band(preset, control), flush=True)
    print(f"\ntotal: cpu {time.process_time() - c0:.1f} s, wall {time.perf_counter() - w0:.1f} s, "
          f"load average at end: {os.getloadavg()}")


if __name__ == "__main__":
    main()
