"""Compiled population rollout of the GA (one call per generation and scenario).

``rollout_population`` runs whole Case-1 (or constraint-scenario) episodes for every car of a ``BatchSim``: per
control step the controller's compiled per-row law (``baselines.tunable.population_row``, resolved by the law's
type: e.g. ``baselines.smc_tuning.smc_population_row``, the same compiled law the policies run), then the env's
own per-car step ``envs.kernels.step_car`` (speed loop, physics, projection, observation, termination), then the
fitness accumulators (``tuning.accumulators``: ITAE by the trapezoid rule, max|a_y| over the physics substeps,
min F_z). Cars are independent, so each car runs its whole episode in one parallel iteration: a car that
terminates stops costing anything, and the result of car i does not depend on the batch it is in (the same
arithmetic as stepping the batch one control period at a time). Nominal scenarios only: no sensor noise and no
actuator delay (the caller checks).
"""

from __future__ import annotations

import numba

from vtrack_gym._jit import kernel, prange
from vtrack_gym.baselines.tunable import population_row
from vtrack_gym.envs.kernels import CAR_MIN_FZ, E_EY, step_car
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
    ``out[i]`` (``tuning.accumulators`` columns) and return True when its episode is over.
    ``arrays``: the env's ``envs.kernels.SimArrays``; ``max_steer``: its road-wheel angle of action 1 [rad]."""
    err, outputs, car, term = arrays.err, arrays.outputs, arrays.car, arrays.term
    arrays.actions[i] = action
    arrays.inputs[i, L.U_DELTA] = action * max_steer
    step_car(i, arrays)
    abs_ey = abs(err[i, E_EY])
    if abs_ey > out[i, ACC_MAX_EY]:
        out[i, ACC_MAX_EY] = abs_ey
    te = k * dt * abs_ey
    if k >= 2:
        out[i, ACC_ITAE] += 0.5 * dt * (out[i, ACC_LAST_TE] + te)
    out[i, ACC_LAST_TE] = te
    n_sub = outputs.shape[1]
    for j in range(n_sub):
        ay = abs(outputs[i, j, L.O_AY])
        if ay > out[i, ACC_MAX_AY]:
            out[i, ACC_MAX_AY] = ay
        if acc_buf.shape[1] > 0:
            for c in range(N_BUF):  # a_x, a_y, a_z: consecutive in both arrays
                acc_buf[i, (k - 1) * n_sub + j, BUF_AX + c] = outputs[i, j, L.O_AX + c]
    if car[i, CAR_MIN_FZ] < out[i, ACC_MIN_FZ]:
        out[i, ACC_MIN_FZ] = car[i, CAR_MIN_FZ]
    out[i, ACC_STEPS] = k
    return term[i] != 0 or k >= max_steps


def _rollout_population(arrays, env_max_steer, lanes, max_steps, dt, law, memory, inv_steer, nan_to_zero, acc_buf,
                        out):
    """Whole episodes of every car under its own parameter row (``population_row(law, obs, i, memory[i])`` ->
    road-wheel angle [rad]; see the module docstring); ``out`` (n, N_ACC). ``lanes``: number of parallel lanes (the
    thread count); each lane runs a contiguous block of cars, so two threads never write the same cache line except
    at a block boundary (interleaved cars ran ~1.45x slower on 2 threads from false sharing)."""
    obs = arrays.obs
    n = obs.shape[0]
    for lane in prange(lanes):
        for i in range(lane * n // lanes, (lane + 1) * n // lanes):
            for step in range(1, max_steps + 1):
                delta = population_row(law, obs, i, memory[i])
                if _advance(i, step, _normalised(delta, inv_steer, nan_to_zero), arrays, env_max_steer, max_steps,
                            dt, acc_buf, out):
                    break


_CACHED = kernel(parallel=True)(_rollout_population)
_UNCACHED = numba.njit(parallel=True)(_rollout_population)


def rollout_population(arrays, env_max_steer, lanes, max_steps, dt, law, memory, inv_steer, nan_to_zero, acc_buf,
                       out) -> None:
    """``_rollout_population`` compiled for the type of ``law``. The package's own laws use the on-disk cache; a
    law type defined elsewhere compiles in its process only: numba keeps every signature of a kernel in one cache
    index, and an entry naming a module another process cannot import (a script's, a test's) would make that index
    unreadable there, for every law."""
    kernel = _CACHED if type(law).__module__.startswith("vtrack_gym.") else _UNCACHED
    kernel(arrays, env_max_steer, lanes, max_steps, dt, law, memory, inv_steer, nan_to_zero, acc_buf, out)
