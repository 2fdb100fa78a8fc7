"""The two ways a population episode is rolled out on a ``BatchSim``, with the fitness accumulators.

* ``run_compiled``: every car's whole episode in one numba call (``vtrack_gym.tuning._kernels``: the controller's
  compiled per-row law, the env's own per-car step and the ITAE / max|a_y| (physics substeps) / min F_z
  accumulators, cars spread over the threads in contiguous blocks); a car that terminates stops costing time.
  Nominal scenarios only, and only for a population policy with ``compiled_rows`` (``baselines.tunable``).
* ``run_stepwise``: the reference: the policy's numpy-facing ``act`` and ``BatchSim.step``, one control period at
  a time (slower; the tests compare the compiled rollout against it).

Both fill ``out`` (n, ``accumulators.N_ACC``, columns ``accumulators.ACC_*``) and ``acc_buf`` (n, steps *
substeps, 3) with the body accelerations when it has room (comfort scoring).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from vtrack_gym.baselines.base import Policy
from vtrack_gym.tuning.accumulators import (
    ACC_ITAE,
    ACC_LAST_TE,
    ACC_MAX_AY,
    ACC_MAX_EY,
    ACC_MIN_FZ,
    ACC_STEPS,
    BUF_AX,
    N_BUF,
)
from vtrack_gym.vehicle import layout as L


def distance_done(sim: Any) -> np.ndarray:
    """Distance each car has covered on its track [m] (lap progress on a closed track, station otherwise)."""
    return np.where(sim.tracks.closed[sim.veh_track], sim.progress, sim.station_m)


def run_compiled(sim: Any, policy: Policy, max_steps: int, dt: float, acc_buf: np.ndarray, out: np.ndarray) -> None:
    """Whole episodes of the population ``policy`` (its ``compiled_rows``) in one compiled call."""
    import numba

    from vtrack_gym.tuning import _kernels as K

    if sim.noise.active or sim.delay.active:
        raise ValueError("the compiled population rollout runs nominal scenarios only (no noise or delay)")
    rows = getattr(policy, "compiled_rows", None)
    if not callable(rows):
        raise ValueError(f"no compiled population rollout for {type(policy).__name__} (no compiled_rows)")
    compiled = rows(sim.obs.astype(np.float64))
    n = sim.n
    lanes = max(1, min(n, numba.get_num_threads()))
    K.rollout_population(sim.arrays, float(sim.max_steer_rad), lanes, max_steps, dt, compiled.law,
                         np.ascontiguousarray(compiled.memory, dtype=np.float64), 1.0 / policy.max_steer_rad,
                         bool(compiled.nan_to_zero), acc_buf, out)
    sim.steps[:] = out[:, ACC_STEPS].astype(np.int64)


def run_stepwise(sim: Any, policy: Policy, max_steps: int, dt: float, acc_buf: np.ndarray,
                 out: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Reference path, one control period at a time. Returns each car's termination code and distance driven
    [m] when its episode ended (the batch keeps stepping finished cars with zero steering)."""
    n = sim.n
    code = np.zeros(n, dtype=np.int64)
    done_dist = np.zeros(n)
    inv_steer = 1.0 / policy.max_steer_rad
    obs = sim.obs.astype(np.float64)
    state = policy.initial_state(obs)
    active = np.ones(n, dtype=bool)
    n_sub = sim.n_sub
    i_vx = policy.layout.index("v_x")
    for k in range(1, max_steps + 1):
        delta, state = policy.act(obs, state)
        action = np.clip(delta * inv_steer, -1.0, 1.0)
        action[~active] = 0.0
        sim.step(action)
        abs_ey = np.abs(sim.lateral_error_m)
        te = k * dt * abs_ey
        a = active
        if k >= 2:
            out[a, ACC_ITAE] += 0.5 * dt * (out[a, ACC_LAST_TE] + te[a])
        out[a, ACC_LAST_TE] = te[a]
        out[a, ACC_MAX_AY] = np.maximum(out[a, ACC_MAX_AY], np.abs(sim.outputs[a, :, L.O_AY]).max(axis=1))
        out[a, ACC_MIN_FZ] = np.minimum(out[a, ACC_MIN_FZ], sim.min_fz[a])
        out[a, ACC_STEPS] = k
        out[a, ACC_MAX_EY] = np.maximum(out[a, ACC_MAX_EY], abs_ey[a])
        if acc_buf.shape[1]:
            acc_buf[a, (k - 1) * n_sub:k * n_sub, BUF_AX:BUF_AX + N_BUF] = sim.outputs[a, :, L.O_AX:L.O_AZ + 1]
        ended = active & ((sim.term != 0) | (k >= max_steps))
        code[ended] = sim.term[ended]
        done_dist[ended] = distance_done(sim)[ended]
        active = active & ~ended
        if not active.any():
            break
        obs = sim.obs.astype(np.float64)
        obs[~active] = 0.0
        obs[~active, i_vx] = 10.0  # a harmless speed for frozen rows (their output is discarded)
    return code, done_dist
