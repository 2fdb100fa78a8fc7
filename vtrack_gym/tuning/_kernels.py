"""Compiled population rollouts of the GA (one call per generation and scenario).

``rollout_smc`` / ``rollout_mpc`` run whole Case-1 (or constraint-scenario) episodes for every car of a
``BatchSim``: per control step the controller law of car i (``vtrack_gym.baselines.laws.smc_row`` / ``mpc_row``: the
same compiled law the policies run), then the env's own per-car step ``envs.kernels.step_car`` (speed loop,
physics, projection, observation, termination), then the fitness accumulators (ITAE by the trapezoid rule,
max|a_y| over the physics substeps, min F_z). Cars are independent, so each car runs its whole episode in one
parallel iteration: a car that terminates stops costing anything, and the result of car i does not depend on
the batch it is in (the same arithmetic as stepping the batch one control period at a time).
Nominal scenarios only: no sensor noise and no actuator delay (the caller checks).
"""

from __future__ import annotations

from vtrack_gym._jit import kernel, prange
from vtrack_gym.baselines.laws import MPCLaw, SMCLaw, mpc_row, smc_row
from vtrack_gym.envs.kernels import CAR_MIN_FZ, step_car
from vtrack_gym.vehicle import layout as L


@kernel
def _normalised(delta: float, inv_steer: float, nan_to_zero: bool) -> float:
    """Road-wheel angle [rad] -> action in [-1, 1] (with ``nan_to_zero``, a diverged row steers neutral)."""
    a = delta * inv_steer
    if nan_to_zero and not (a == a):
        a = 0.0
    return 1.0 if a > 1.0 else (-1.0 if a < -1.0 else a)


@kernel
def _advance(i, k, action, arrays, max_steer, max_steps, dt, acc_buf, out) -> bool:
    """Apply ``action`` to car ``i`` for control step ``k`` (1-based), accumulate its fitness terms into
    ``out[i]`` (ITAE, last t|e_y|, max|a_y|, min F_z, steps, max|e_y|) and return True when its episode is over.
    ``arrays``: the env's ``envs.kernels.SimArrays``; ``max_steer``: its road-wheel angle of action 1 [rad]."""
    err, outputs, car, term = arrays.err, arrays.outputs, arrays.car, arrays.term
    arrays.actions[i] = action
    arrays.inputs[i, L.U_DELTA] = action * max_steer
    step_car(i, arrays)
    abs_ey = abs(err[i, 1])
    if abs_ey > out[i, 5]:
        out[i, 5] = abs_ey
    te = k * dt * abs_ey
    if k >= 2:
        out[i, 0] += 0.5 * dt * (out[i, 1] + te)
    out[i, 1] = te
    n_sub = outputs.shape[1]
    for j in range(n_sub):
        ay = abs(outputs[i, j, L.O_AY])
        if ay > out[i, 2]:
            out[i, 2] = ay
        if acc_buf.shape[1] > 0:
            for c in range(3):
                acc_buf[i, (k - 1) * n_sub + j, c] = outputs[i, j, L.O_AX + c]
    if car[i, CAR_MIN_FZ] < out[i, 3]:
        out[i, 3] = car[i, CAR_MIN_FZ]
    out[i, 4] = k
    return term[i] != 0 or k >= max_steps


@kernel(parallel=True)
def rollout_smc(arrays, env_max_steer, lanes, max_steps, dt, law: SMCLaw, inv_steer, acc_buf, out):
    """Whole episodes of every car under its own SMC gains (row i of ``law``; see the module docstring);
    ``out`` (n, 6). ``lanes``: number of parallel lanes (the thread count); each lane runs a contiguous block of
    cars, so two threads never write the same cache line except at a block boundary (interleaved cars ran ~1.45x
    slower on 2 threads from false sharing)."""
    obs = arrays.obs
    n = obs.shape[0]
    for lane in prange(lanes):
        for i in range(lane * n // lanes, (lane + 1) * n // lanes):
            for step in range(1, max_steps + 1):
                delta, _, _ = smc_row(law, obs, i)
                if _advance(i, step, _normalised(delta, inv_steer, True), arrays, env_max_steer, max_steps, dt, acc_buf,
                            out):
                    break


@kernel(parallel=True)
def rollout_mpc(arrays, env_max_steer, lanes, max_steps, dt, law: MPCLaw, inv_steer, state, z, acc_buf, out):
    """Whole episodes of every car under its own MPC gain table (row i of ``law``); ``state`` (n, 9) the MPC
    memory (initialised), ``z`` (n, width) scratch."""
    obs = arrays.obs
    n = obs.shape[0]
    for lane in prange(lanes):
        for i in range(lane * n // lanes, (lane + 1) * n // lanes):
            for step in range(1, max_steps + 1):
                u = mpc_row(law, obs, i, state[i], z[i])
                if _advance(i, step, _normalised(u, inv_steer, False), arrays, env_max_steer, max_steps, dt, acc_buf,
                            out):
                    break
