"""The two ways a population episode is rolled out on a ``BatchSim``, with the fitness accumulators.

* ``run_compiled``: every car's whole episode in one numba call (``vtrack_gym.tuning._kernels``: the controller
  law, the env's own per-car step and the ITAE / max|a_y| (physics substeps) / min F_z accumulators, cars spread
  over the threads in contiguous blocks); a car that terminates stops costing time. Nominal scenarios only.
* ``run_stepwise``: the reference: the policy's numpy-facing ``act`` and ``BatchSim.step``, one control period at
  a time (slower; the tests compare the compiled rollout against it).

Both fill ``out`` (n, 6): ITAE [m s^2], last t|e_y| [m s], max|a_y| [m/s^2], min F_z [N], steps driven, max|e_y|
[m]; and ``acc_buf`` (n, steps * substeps, 3) with the body accelerations when it has room (comfort scoring).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from vtrack_gym.baselines.base import Policy
from vtrack_gym.baselines.laws import MPCLaw, SMCLaw
from vtrack_gym.vehicle import layout as L


def distance_done(sim: Any) -> np.ndarray:
    """Distance each car has covered on its track [m] (lap progress on a closed track, station otherwise)."""
    return np.where(sim.tracks.closed[sim.veh_track], sim.progress, sim.station_m)


def run_compiled(sim: Any, policy: Policy, max_steps: int, dt: float, acc_buf: np.ndarray, out: np.ndarray) -> None:
    """Whole episodes of the population ``policy`` (a ``PopulationSMC`` / ``PopulationMPC``) in one compiled call."""
    import numba

    from vtrack_gym.tuning import _kernels as K

    if sim.noise.active or sim.delay.active:
        raise ValueError("the compiled population rollout runs nominal scenarios only (no noise or delay)")
    n = sim.n
    lanes = max(1, min(n, numba.get_num_threads()))
    sim_args = (sim.arrays, float(sim.max_steer_rad))  # numba takes the NamedTuple directly
    law = getattr(policy, "law", None)
    inv_steer = 1.0 / policy.max_steer_rad
    if isinstance(law, SMCLaw):
        K.rollout_smc(*sim_args, lanes, max_steps, dt, law, inv_steer, acc_buf, out)
    elif isinstance(law, MPCLaw):
        state = np.ascontiguousarray(policy.initial_state(sim.obs.astype(np.float64)))
        K.rollout_mpc(*sim_args, lanes, max_steps, dt, law, inv_steer, state, np.zeros((n, law.tables.shape[2])),
                      acc_buf, out)
    else:
        raise ValueError(f"no compiled population rollout for {type(policy).__name__}")
    sim.steps[:] = out[:, 4].astype(np.int64)


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
        te = k * dt * np.abs(sim.lateral_error_m)
        a = active
        if k >= 2:
            out[a, 0] += 0.5 * dt * (out[a, 1] + te[a])
        out[a, 1] = te[a]
        out[a, 2] = np.maximum(out[a, 2], np.abs(sim.outputs[a, :, L.O_AY]).max(axis=1))
        out[a, 3] = np.minimum(out[a, 3], sim.min_fz[a])
        out[a, 4] = k
        out[a, 5] = np.maximum(out[a, 5], np.abs(sim.lateral_error_m[a]))
        if acc_buf.shape[1]:
            acc_buf[a, (k - 1) * n_sub:k * n_sub] = sim.outputs[a, :, L.O_AX:L.O_AZ + 1]
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
