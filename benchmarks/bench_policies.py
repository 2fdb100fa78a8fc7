"""Steering baselines: predict cost per single call and per observation in a batch of 4096, side by side.

Targets: precomputed-gain MPC and SMC under 20 us per single call; OSQP MPC under 150 us per step.
The MPCs recompute every round(T_s / T_c) = 2 env steps and hold in between, so "per call" is the mean over
calls; the "solve" rows force a recomputation on every call (the cost of one MPC sample).
Run: ``python benchmarks/bench_policies.py``.
"""

from __future__ import annotations

import math
import time
from types import SimpleNamespace

import numpy as np
from _timing import rate

from vtrack_gym.baselines.registry import available_policies, make_policy
from vtrack_gym.envs.observation import OBS
from vtrack_gym.vehicle.params import DesignModel, paper_vehicle

BATCH = 4096
ENV = SimpleNamespace(unwrapped=SimpleNamespace(design_model=DesignModel.from_vehicle(paper_vehicle()),
                                                observation_layout=OBS, control_period_s=0.01))
COUNTERS = {"mpc": 8, "mpc_osqp": 1}   # state column of the hold counter
N_SEQUENTIAL = 20000                   # 200 s of driving at 20 m/s


def observations(n: int, seed: int = 0, sequential: bool = False) -> np.ndarray:
    """Plausible observations: speeds 5-35 m/s, small errors, sinusoidal curvature with its preview.

    ``sequential``: one car at 20 m/s, consecutive control periods (what a controller sees in a closed loop,
    so warm starts are realistic); otherwise independent random cars.
    """
    rng = np.random.default_rng(seed)
    obs = np.zeros((n, OBS.size))
    if sequential:
        v = np.full(n, 20.0)
        s = 20.0 * 0.01 * np.arange(n)
    else:
        v = rng.uniform(5.0, 35.0, n)
        s = rng.uniform(0.0, 500.0, n)
    amp, wave = 0.01, 2.0 * math.pi / 150.0
    if sequential:
        obs[:, OBS.E_Y] = 0.05 * np.sin(0.5 * s / 20.0)
        obs[:, OBS.E_Y_DOT] = 0.025 * np.cos(0.5 * s / 20.0)
    else:
        obs[:, OBS.E_Y] = rng.normal(0.0, 0.05, n)
        obs[:, OBS.E_PHI] = rng.normal(0.0, 0.01, n)
        obs[:, OBS.E_Y_DOT] = rng.normal(0.0, 0.05, n)
        obs[:, OBS.E_PHI_DOT] = rng.normal(0.0, 0.01, n)
    obs[:, OBS.V_X], obs[:, OBS.TARGET_SPEED] = v, v
    obs[:, OBS.V_Y] = 0.0 if sequential else rng.normal(0.0, 0.1, n)
    kappa = amp * np.sin(wave * s)
    obs[:, OBS.YAW_RATE] = v * kappa + (0.0 if sequential else rng.normal(0.0, 0.01, n))
    obs[:, OBS.ROAD_WHEEL_ANGLE] = 3.0 * kappa
    obs[:, OBS.YAW_RATE_REF] = v * kappa
    obs[:, OBS.YAW_ACC_REF] = v * v * amp * wave * np.cos(wave * s)
    obs[:, OBS.CURVATURE] = kappa
    obs[:, OBS.CURVATURE_RATE] = amp * wave * np.cos(wave * s)
    obs[:, OBS.preview] = amp * np.sin(wave * (s[:, None] + OBS.preview_distances(v)))
    return obs


def single_call_us(name: str, force_solve: bool = False) -> float:
    """Mean wall time [us] of one ``predict`` on a single observation (one car driving along a curvy road,
    state carried between calls)."""
    pol = make_policy(name, ENV)
    obs = observations(N_SEQUENTIAL, sequential=True)
    holder = {"state": None, "i": 0}
    col = COUNTERS.get(name)

    def call() -> None:
        i = holder["i"] = (holder["i"] + 1) % N_SEQUENTIAL
        st = holder["state"]
        if force_solve and st is not None:
            st[0, col] = 0.0
        _, holder["state"] = pol.predict(obs[i], st)

    return 1e6 / rate(call, 1.0)


def batch_us_per_obs(name: str) -> float:
    """Wall time [us] per observation of ``predict`` on a batch of 4096 independent cars (state carried)."""
    pol = make_policy(name, ENV)
    obs = observations(BATCH, seed=1)
    holder = {"state": None}

    def call() -> None:
        _, holder["state"] = pol.predict(obs, holder["state"])

    return 1e6 / rate(call, BATCH, min_seconds=2.0 if name == "mpc_osqp" else 1.0)


def main() -> None:
    start = time.perf_counter()
    print(f"{'policy':<22} {'single [us/call]':>17} {'batch 4096 [us/obs]':>20}")
    for name in available_policies():
        print(f"{name:<22} {single_call_us(name):>17.1f} {batch_us_per_obs(name):>20.2f}", flush=True)
        if name in COUNTERS:
            print(f"{name + ' (solve)':<22} {single_call_us(name, force_solve=True):>17.1f} {'':>20}", flush=True)
    print("targets: mpc and smc < 20 us per single call; mpc_osqp < 150 us per step")
    print(f"(total {time.perf_counter() - start:.0f} s)")


if __name__ == "__main__":
    main()
