"""Env throughput and import time, each as a ratio against a peer measured in the same run.

- single env steps/s of ``LateralTracking-v0`` (random actions, through ``gymnasium.make``) / highway-env's
  ``lane-keeping-v0`` (target >= 10x);
- native vector env-steps/s at N = 4096 / Gymnasium's vector CartPole at N = 4096 (target >= 0.5x);
- ``import vtrack_gym`` time / ``import highway_env`` time (fresh interpreters, best of 5; target < 0.5 s).

Run: ``python benchmarks/bench_env.py``.
"""

from __future__ import annotations

import subprocess
import sys

import gymnasium as gym
import numpy as np
from _timing import rate

import vtrack_gym  # noqa: F401  (registers the ids)


def single_env_rate(env_id: str) -> float:
    env = gym.make(env_id)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    actions = rng.uniform(-0.05, 0.05, (4096, 1)).astype(np.float32)
    counter = [0]

    def one() -> None:
        _, _, term, trunc, _ = env.step(actions[counter[0] % 4096])
        counter[0] += 1
        if term or trunc:
            env.reset()

    return rate(one, 1, min_seconds=3.0)


def vector_rate(env_id: str, n: int, **kwargs: object) -> float:
    envs = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", **kwargs)
    envs.reset(seed=0)
    actions = envs.action_space.sample()
    if actions.dtype.kind == "f":
        actions = actions * 0.05  # gentle steering, the cars stay on the road
    return rate(lambda: envs.step(actions), n, min_seconds=3.0)


def import_time(module: str) -> float:
    code = f"import time; t = time.perf_counter(); import {module}; print(time.perf_counter() - t)"
    times = [float(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout)
             for _ in range(5)]
    return min(times)


def main() -> None:
    ours = single_env_rate("LateralTracking-v0")
    rows = [("single env steps/s", "LateralTracking-v0", ours)]
    try:
        import highway_env  # noqa: F401

        peer = single_env_rate("lane-keeping-v0")
        rows.append(("single env steps/s", "highway-env lane-keeping-v0", peer))
        ratio_single = ours / peer
    except ImportError:
        ratio_single = float("nan")
    vec = vector_rate("LateralTracking-v0", 4096)
    cart = vector_rate("CartPole-v1", 4096)
    rows += [("vector env-steps/s N=4096", "LateralTracking-v0", vec),
             ("vector env-steps/s N=4096", "CartPole-v1 (Gymnasium)", cart)]
    for what, who, value in rows:
        print(f"{what:<28} {who:<30} {value:>14,.0f}")
    print(f"ratio single env vs highway-env lane-keeping: {ratio_single:6.1f}x   (target >= 10x)")
    print(f"ratio vector env vs Gymnasium CartPole:       {vec / cart:6.3f}x  (target >= 0.5x)")
    t_ours = import_time("vtrack_gym")
    try:
        t_hw = import_time("highway_env")
    except subprocess.CalledProcessError:
        t_hw = float("nan")
    print(f"import vtrack_gym: {t_ours:.3f} s   import highway_env: {t_hw:.3f} s   (target < 0.5 s)")


if __name__ == "__main__":
    main()
