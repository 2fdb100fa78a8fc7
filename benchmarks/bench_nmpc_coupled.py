"""The coupled NMPC (``nmpc_coupled``: steering and longitudinal demand in one real-time iteration) against the
steering NMPC paired with the PD-FLC (``nmpc`` in ``steer_accel``), in one run: tracking and compute per decision.

Each policy drives one closed-loop episode per scenario in ``control="steer_accel"`` (seed 0). Per decision, on
this thread's CPU clock (``time.thread_time``): the *feedback* phase (``predict`` with ``defer_preparation``:
observation to command) and the *preparation* phase (``prepare()``, after the command is sent); the same for the
steering NMPC inside the pairing. Also max |e_y| [m], RMS speed error [m/s] over the episode (time-weighted, as
the rows' ``rms_e_v_mps``), the RMS speed error after the car first reaches its reference speed, the last time
error [s], and the load average.
Targets: max |e_y| within 25 % of the steering NMPC's steer-mode figure (DLC120-v0 0.108 m, LateralTracking-v0
0.035 m); RMS speed error under 0.5 m/s.
Run: ``python benchmarks/bench_nmpc_coupled.py [ENV_ID ...]`` (default: LateralTracking-v0 and DLC120-v0).
"""

from __future__ import annotations

import os
import sys
import time
from typing import Any

import gymnasium as gym
import numpy as np

import vtrack_gym

POLICIES = ("nmpc_coupled", "nmpc")
STEER_MODE_MAX_EY_M = {"DLC120-v0": 0.108, "LateralTracking-v0": 0.035}
"""The steering NMPC's max |e_y| [m] in the steer mode (the Baselines page, NMPC)."""
TARGET_EY_FRACTION, TARGET_RMS_EV_MPS = 1.25, 0.5


def _solver(policy: Any) -> Any:
    """The object with ``defer_preparation`` / ``prepare()``: the steering law of a pairing, or the policy."""
    return getattr(policy, "lateral", policy)


def episode(name: str, env_id: str) -> dict[str, Any]:
    """CPU seconds of every decision's feedback and preparation and the tracking figures of one episode."""
    env = gym.make(env_id, control="steer_accel")
    policy = vtrack_gym.make_policy(name, env)
    solver = _solver(policy)
    solver.defer_preparation = True
    obs, _ = env.reset(seed=0)
    feedback, preparation, e_y, e_v, state, start = [], [], [], [], None, True
    while True:
        c0 = time.thread_time()
        action, state = policy.predict(obs, state=state, episode_start=start)
        c1 = time.thread_time()
        solver.prepare()
        feedback.append(c1 - c0)
        preparation.append(time.thread_time() - c1)
        start = False
        obs, _, terminated, truncated, info = env.step(action)
        e_y.append(abs(float(info["e_y_m"])))
        e_v.append(float(info["speed_error_mps"]))
        if terminated or truncated:
            ev = np.array(e_v)
            reached = int(np.argmax(ev > -0.05)) if np.any(ev > -0.05) else ev.size
            return {"feedback": np.array(feedback), "preparation": np.array(preparation), "max_ey": max(e_y),
                    "rms_ev": float(np.sqrt(np.mean(ev ** 2))), "reached_s": reached * env.unwrapped.control_period_s,
                    "rms_ev_after": float(np.sqrt(np.mean(ev[reached:] ** 2))) if reached < ev.size else np.nan,
                    "time_error": float(info["time_error_s"]), "success": bool(info.get("success", False))}


def _percentiles(x: np.ndarray) -> str:
    return f"{np.percentile(x, 50) * 1e6:6.0f} / {np.percentile(x, 95) * 1e6:6.0f}"


def main(env_ids: list[str]) -> None:
    print(f"load average {os.getloadavg()[0]:.1f}; control='steer_accel', seed 0; CPU per decision [us] (p50 / p95), "
          "thread clock")
    print(f"{'scenario':19s} {'policy':13s} {'feedback':>15s} {'preparation':>15s} {'max|e_y| m':>10s} "
          f"{'RMS e_v':>8s} {'reach s':>7s} {'RMS e_v after':>13s} {'e_t end s':>9s} success")
    print(f"{'':19s} {'':13s} {'total':>15s}")
    for env_id in env_ids:
        for name in POLICIES:
            r = episode(name, env_id)
            print(f"{env_id:19s} {name:13s} {_percentiles(r['feedback']):>15s} {_percentiles(r['preparation']):>15s} "
                  f"{r['max_ey']:10.4f} {r['rms_ev']:8.3f} {r['reached_s']:7.2f} {r['rms_ev_after']:13.3f} "
                  f"{r['time_error']:9.3f} {r['success']}", flush=True)
            print(f"{'':19s} {'':13s} {_percentiles(r['feedback'] + r['preparation']):>15s}")
            if name == "nmpc_coupled" and env_id in STEER_MODE_MAX_EY_M:
                ratio = r["max_ey"] / STEER_MODE_MAX_EY_M[env_id]
                print(f"{'':19s} max|e_y| / nmpc's steer figure {ratio:.3f} (target <= {TARGET_EY_FRACTION}); "
                      f"RMS e_v {r['rms_ev']:.3f} m/s (target < {TARGET_RMS_EV_MPS}); load "
                      f"{os.getloadavg()[0]:.1f}", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:] or ["LateralTracking-v0", "DLC120-v0"])
