"""CPU time of the per-episode harness work of ``vtrack benchmark`` that the results do not depend on, old way and
new way side by side in one process (so the machine's load hits both alike).

For one episode of ``lqr`` on each of the paper suite's envs (the infos and the trace of a real rollout):

* the trace's signal table from the infos: a list of rows into ``np.array`` (old) against ``np.fromiter`` (new);
* the ISO 2631-1 comfort figures: ``vibration_total`` plus the x axis filtered again (old) against
  ``vibration_axes`` (each axis once, new);
* the policy hash of the second episode of a policy: probed again (old) against ``policy_hash(..., seen)`` (new);

each the median of ``--repeats`` timings [ms of CPU], with the results checked equal. Load average printed.
Run: ``python benchmarks/bench_harness_savings.py [--repeats 5]``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from collections.abc import Callable
from itertools import chain
from operator import itemgetter
from typing import Any

import numpy as np

ENV_IDS = ("DLC120-v0", "LateralTracking-v0")
POLICIES = ("lqr", "smc", "ppo", "nmpc")


def cpu_ms(fn: Callable[[], Any], repeats: int) -> tuple[float, Any]:
    """Median CPU time [ms] of ``fn()`` over ``repeats`` calls, and its last result."""
    times, out = [], None
    for _ in range(repeats):
        start = time.process_time()
        out = fn()
        times.append(1e3 * (time.process_time() - start))
    return statistics.median(times), out


def episode_infos(env_id: str) -> tuple[list[dict], Any]:
    """The infos and the trace of one ``lqr`` episode (seed 0)."""
    import gymnasium as gym

    import vtrack_gym
    from vtrack_gym.evaluation.rollouts.rollout import rollout

    env = gym.make(env_id)
    policy = vtrack_gym.make_policy("lqr", env)
    obs, _ = env.reset(seed=0)
    infos = []
    while True:
        obs, _, terminated, truncated, info = env.step(policy.predict(obs)[0])
        infos.append(info)
        if terminated or truncated:
            return infos, rollout(policy, env, seed=0)


def table_rows(infos: list[dict], repeats: int) -> tuple[float, float]:
    from vtrack_gym.evaluation.scoring.trace import STEP_SIGNALS

    row_of, width = itemgetter(*STEP_SIGNALS), len(STEP_SIGNALS)
    old, a = cpu_ms(lambda: np.array([row_of(i) for i in infos], dtype=np.float64).reshape(len(infos), width),
                    repeats)
    new, b = cpu_ms(lambda: np.fromiter(chain.from_iterable(map(row_of, infos)), dtype=np.float64,
                                        count=len(infos) * width).reshape(len(infos), width), repeats)
    assert np.array_equal(a, b)
    return old, new


def comfort(trace: Any, repeats: int) -> tuple[float, float]:
    from vtrack_gym.evaluation.scoring import iso2631

    acc, fs = trace.acc_physics_mps2, trace.physics_rate_hz
    old, a = cpu_ms(lambda: (iso2631.vibration_total(acc[:, 0], acc[:, 1], acc[:, 2], fs),
                             iso2631.weighted_rms(acc[:, 0], fs, "Wd")), repeats)
    new, b = cpu_ms(lambda: iso2631.vibration_axes(acc[:, 0], acc[:, 1], acc[:, 2], fs), repeats)
    assert a == (b[0], b[1][0])
    return old, new


def second_hash(name: str, repeats: int) -> tuple[float, float]:
    import gymnasium as gym

    import vtrack_gym
    from vtrack_gym.evaluation.identity.fingerprint import policy_hash

    env = gym.make(ENV_IDS[0])
    seen: dict[str, str] = {}
    first = policy_hash(vtrack_gym.make_policy(name, env), env, seen)
    old, a = cpu_ms(lambda: policy_hash(vtrack_gym.make_policy(name, env), env), repeats)
    new, b = cpu_ms(lambda: policy_hash(vtrack_gym.make_policy(name, env), env, seen), repeats)
    assert a == b == first
    return old, new


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    print(f"load average {os.getloadavg()[0]:.1f}; CPU [ms] per episode, median of {args.repeats}: old -> new")
    for env_id in ENV_IDS:
        infos, trace = episode_infos(env_id)
        old, new = table_rows(infos, args.repeats)
        print(f"{env_id:<20} {len(infos):6d} steps   signal table {old:7.1f} -> {new:7.1f}", flush=True)
        old, new = comfort(trace, args.repeats)
        print(f"{env_id:<20} {'':12s} comfort      {old:7.1f} -> {new:7.1f}", flush=True)
    for name in POLICIES:
        old, new = second_hash(name, args.repeats)
        print(f"{name:<20} {'':12s} 2nd hash     {old:7.1f} -> {new:7.1f}", flush=True)
    print(f"load average {os.getloadavg()[0]:.1f} at the end")


if __name__ == "__main__":
    main()
