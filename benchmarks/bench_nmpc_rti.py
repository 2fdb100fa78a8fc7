"""The NMPC's compute per decision, the compiled real-time iteration (``nmpc``, preset ``default``) against CasADi's
iteration (preset ``casadi``, the default before) and five iterations (``converged``), in one run.

Each policy drives one closed-loop episode per scenario (seed 0). Per decision, on this thread's CPU clock
(``time.thread_time``: what the decision costs on an idle core): the *feedback* phase (``predict`` with
``defer_preparation``: observation to command, what a loop with compute charged pays) and the *preparation*
phase (``prepare()``: linearising and condensing for the next decision, after the command is sent). The CasADi
presets have no split: everything is feedback. Also the tracking (max |e_y| [m]) and the load average.
Target: feedback p50 at most 150 us; max |e_y| within 5 % of the ``casadi`` preset on both scenarios.
Run: ``python benchmarks/bench_nmpc_rti.py [ENV_ID ...]`` (default: LateralTracking-v0 and DLC120-v0).
"""

from __future__ import annotations

import os
import sys
import time

import gymnasium as gym
import numpy as np

import vtrack_gym  # noqa: F401
from vtrack_gym.baselines.nmpc import NMPC

PRESETS = ("default", "casadi", "converged")
TARGET_FEEDBACK_US = 150.0


def episode(preset: str, env_id: str) -> tuple[np.ndarray, np.ndarray, float]:
    """CPU seconds of every decision's feedback and preparation, and max |e_y| [m], of one closed-loop episode."""
    env = gym.make(env_id)
    policy = NMPC.from_env(env, preset)
    policy.defer_preparation = True
    obs, _ = env.reset(seed=0)
    feedback, preparation, worst = [], [], 0.0
    state, start = None, True
    while True:
        c0 = time.thread_time()
        action, state = policy.predict(obs, state=state, episode_start=start)
        c1 = time.thread_time()
        policy.prepare()
        feedback.append(c1 - c0)
        preparation.append(time.thread_time() - c1)
        start = False
        obs, _, terminated, truncated, info = env.step(action)
        worst = max(worst, abs(float(info["e_y_m"])))
        if terminated or truncated:
            return np.array(feedback), np.array(preparation), worst


def main(env_ids: list[str]) -> None:
    print(f"load average {os.getloadavg()[0]:.1f}; CPU per decision [us] (p50 / p95), thread clock")
    print(f"{'scenario':20s} {'preset':10s} {'feedback':>15s} {'preparation':>15s} {'total':>15s} {'max|e_y| m':>11s}")
    for env_id in env_ids:
        worst_of = {}
        for preset in PRESETS:
            fb, prep, worst = episode(preset, env_id)
            total = fb + prep
            cols = [f"{np.percentile(x, 50) * 1e6:6.0f} / {np.percentile(x, 95) * 1e6:6.0f}" for x in (fb, prep, total)]
            worst_of[preset] = worst
            print(f"{env_id:20s} {preset:10s} {cols[0]:>15s} {cols[1]:>15s} {cols[2]:>15s} {worst:11.5f}", flush=True)
        print(f"{'':20s} default's max|e_y| vs casadi: {100 * (worst_of['default'] / worst_of['casadi'] - 1):+.2f} % "
              f"(target within 5 %); load {os.getloadavg()[0]:.1f}")
    print(f"target: default feedback p50 <= {TARGET_FEEDBACK_US:g} us")


if __name__ == "__main__":
    main(sys.argv[1:] or ["LateralTracking-v0", "DLC120-v0"])
