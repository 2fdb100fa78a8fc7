"""Wall time of evaluating one full LateralTracking-v0 episode (~215 s of driving) with each baseline.

Reported as wall seconds and as a real-time factor (simulated seconds per wall second), with the policy's
share of the time. Target (issue 5): MPC under one second per full episode. Run:
``python benchmarks/bench_evaluation.py``.
"""

from __future__ import annotations

import time

import gymnasium as gym

import vtrack_gym  # noqa: F401
from vtrack_gym.baselines.registry import available_policies, make_policy
from vtrack_gym.evaluation.rollouts.rollout import rollout


def main() -> None:
    print(f"{'policy':<14} {'wall [s]':>9} {'sim [s]':>8} {'x real time':>12} {'termination':>12}")
    for name in available_policies():
        env = gym.make("LateralTracking-v0")
        policy = make_policy(name, env)
        rollout(policy, env, seed=0, max_steps=10)  # warm-up: compiled kernels, gain tables
        best = float("inf")
        for _ in range(3):
            start = time.perf_counter()
            trace = rollout(policy, env, seed=0)
            best = min(best, time.perf_counter() - start)
        sim = trace["time_s"][-1]
        print(f"{name:<14} {best:>9.2f} {sim:>8.1f} {sim / best:>11.0f}x {trace.termination:>12}")
    print("target: mpc < 1 s per full episode")


if __name__ == "__main__":
    main()
