"""Every steering baseline's compute per decision in the closed loop on DLC120-v0 (seed 0), as ratios to the OSQP
MPC measured in the same run.

Per decision: wall time (``time.perf_counter``, what the leaderboard's ``policy_time_*_us`` report) and the
thread's CPU time (``time.thread_time``: what the decision costs on an idle core, without the waiting a shared
machine adds). The MPCs that hold their output between samples (mpc, mpc_osqp: every 2nd period) have a median
near the cost of a hold. Goal: nmpc's p95 under the env's 10 ms control period.
Run: ``python benchmarks/bench_policy_compute.py``.
"""

from __future__ import annotations

import time

import gymnasium as gym
import numpy as np

import vtrack_gym  # noqa: F401
from vtrack_gym.baselines.registry import available_policies, make_policy

PEER = "mpc_osqp"


def decision_times(name: str, env_id: str = "DLC120-v0") -> tuple[np.ndarray, np.ndarray]:
    """Wall and CPU seconds of every decision of one closed-loop episode."""
    env = gym.make(env_id)
    policy = make_policy(name, env)
    obs, _ = env.reset(seed=0)
    wall, cpu = [], []
    state, start = None, True
    while True:
        t0, c0 = time.perf_counter(), time.thread_time()
        action, state = policy.predict(obs, state=state, episode_start=start)
        cpu.append(time.thread_time() - c0)
        wall.append(time.perf_counter() - t0)
        start = False
        obs, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            return np.array(wall), np.array(cpu)


def main() -> None:
    rows = {}
    for name in available_policies():
        wall, cpu = decision_times(name)
        rows[name] = (np.percentile(wall, (50, 95)) * 1e6, wall.max() * 1e6, np.percentile(cpu, (50, 95)) * 1e6)
    peer = rows[PEER][2][0]
    print(f"{'policy':12s} {'wall p50':>9s} {'wall p95':>9s} {'wall max':>9s} {'cpu p50':>9s} {'cpu p95':>9s}  "
          f"cpu p50 / {PEER}")
    for name, ((w50, w95), wmax, (c50, c95)) in rows.items():
        print(f"{name:12s} {w50:9.0f} {w95:9.0f} {wmax:9.0f} {c50:9.0f} {c95:9.0f}  {c50 / peer:8.2f}x   [us]")


if __name__ == "__main__":
    main()
