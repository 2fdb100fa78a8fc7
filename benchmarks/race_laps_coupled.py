"""The race baseline's coupled form against the decoupled one, in one run: ``raceline_coupled`` (the coupled NMPC
on the racing line and its profile) and ``raceline`` (LQR steering, feed-forward/P speed law).

    python benchmarks/race_laps_coupled.py

For each shipped circuit (``vtrack/Race-v0``: the handling course, ``vtrack/RaceRing-v0``: the example ring), seed
0, two laps from a standing start (the env's default): lap times, best lap / the car's lap-time bound, track-limit
excursions under the wheels rule and the body's least edge margin, the wall time of the episode and the load
average.
"""

from __future__ import annotations

import os
import time

import gymnasium as gym

import vtrack_gym

CIRCUITS = {"handling_course": "vtrack/Race-v0", "ring": "vtrack/RaceRing-v0"}
POLICIES = ("raceline", "raceline_coupled")


def run(env: gym.Env, name: str) -> dict:
    """One episode of ``name`` (the plain loop: the policy keeps its own memory): the last step's info."""
    policy = vtrack_gym.make_policy(name, env)
    obs, info = env.reset(seed=0)
    policy.reset()
    while True:
        obs, _, terminated, truncated, info = env.step(policy.predict(obs)[0])
        if terminated or truncated:
            return info


def main() -> None:
    print(f"load average {os.getloadavg()[0]:.1f}")
    print("| circuit | baseline | lap_times_s | best_lap_s | lap_time_bound_s | lap_time_fraction | "
          "track_limit_violations | min_edge_margin_m | termination | wall_s |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for circuit, env_id in CIRCUITS.items():
        env = gym.make(env_id)
        for name in POLICIES:
            start = time.perf_counter()
            info = run(env, name)
            m = env.unwrapped.success_metrics()
            laps = ", ".join(f"{t:.2f}" for t in info["lap_times_s"])
            print(f"| {circuit} | {name} | {laps} | {info['best_lap_s']:.2f} | {info['lap_time_bound_s']:.2f} | "
                  f"{info['lap_time_fraction']:.4f} | {m['track_limit_violations']:.0f} | "
                  f"{m['min_edge_margin_m']:.3f} | {info.get('termination', '')} | "
                  f"{time.perf_counter() - start:.0f} |", flush=True)
    print(f"load average {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
