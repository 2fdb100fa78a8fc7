"""Compiled population rollouts of the GA (one call per generation and scenario).

``rollout_smc`` / ``rollout_mpc`` run whole Case-1 (or constraint-scenario) episodes for every car of a
``BatchSim``: per control step the controller law of car i (the SMC's own ``_coefficients``/``_law`` compiled,
or the MPC's gain-table lookup), then the env's own per-car step ``envs.kernels._step_one`` (speed loop,
physics, projection, observation, termination), then the fitness accumulators (ITAE by the trapezoid rule,
max|a_y| over the physics substeps, min F_z). Cars are independent, so each car runs its whole episode in one
parallel iteration: a car that terminates stops costing anything, and the result of car i does not depend on
the batch it is in (the same arithmetic as stepping the batch one control period at a time).
Nominal scenarios only: no sensor noise and no actuator delay (the caller checks).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from vtrack_gym.baselines.smc import _coefficients, _law
from vtrack_gym.envs.kernels import CAR_MIN_FZ, _step_one
from vtrack_gym.vehicle import layout as L

# The SMC's own coefficient and control-law functions (plain arithmetic), compiled: one source for both paths.
_smc_coefficients = njit(cache=True)(_coefficients)
_smc_law = njit(cache=True)(_law)


@njit(cache=True)
def smc_action(i, obs, idx, k, pole, eta_k, inv_layer, min_speed, v_star, guard, shift, inv_steer) -> float:
    """Normalised steering action of car ``i`` under the SMC law (31) with its own p, eta, Delta."""
    kt = (k[0], k[1], k[2], k[3], k[4], k[5], k[6], k[7])
    v = max(float(obs[i, idx[0]]), min_speed)
    if guard > 0.0 and not math.isnan(v_star) and abs(v - v_star) < guard:
        v = v_star - guard if v < v_star else v_star + guard
    cf = _smc_coefficients(kt, v, pole[i])
    sigma, delta_eq = _smc_law(kt, cf, v, shift, float(obs[i, idx[1]]), float(obs[i, idx[2]]),
                               float(obs[i, idx[3]]), float(obs[i, idx[4]]), float(obs[i, idx[5]]),
                               float(obs[i, idx[6]]), float(obs[i, idx[7]]), float(obs[i, idx[8]]))
    z = sigma * inv_layer[i]
    sat = 1.0 if z > 1.0 else (-1.0 if z < -1.0 else z)
    a = (delta_eq - eta_k[i] * sat) * inv_steer
    if not (a == a):  # NaN (a diverged row): neutral steering
        a = 0.0
    return 1.0 if a > 1.0 else (-1.0 if a < -1.0 else a)


@njit(cache=True)
def mpc_action(p, obs, idx, pv0, pv1, pv_vmin, pv_dt, preview, n_out, ts, n_hold, max_du, max_steer, speeds,
               tables, slopes, inv_steer, state, z) -> float:
    """Normalised steering action of car ``p`` (``MPC._act_batch`` with row p's gain table); updates the
    controller memory ``state[p]`` (9,) and uses ``z`` (width,) as scratch."""
    iv, ivy, ir, iey, ieyd, iep, iepd, iacc, ik, ikr = idx[0], idx[1], idx[2], idx[3], idx[4], idx[5], idx[6], \
        idx[7], idx[9], idx[10]
    st = state[p]
    if st[8] >= 0.5:
        st[8] -= 1.0
    else:
        half = 0.5 * ts
        two_pi = 2.0 * math.pi
        s_last = speeds.shape[0] - 2
        width = tables.shape[2]
        vy, r, ey, eyd, ep, epd = float(obs[p, ivy]), float(obs[p, ir]), float(obs[p, iey]), \
            float(obs[p, ieyd]), float(obs[p, iep]), float(obs[p, iepd])
        v_x = float(obs[p, iv])
        if preview:
            v = max(v_x, 0.0)
            x1 = max(v, pv_vmin) * pv_dt
            d0 = float(obs[p, iacc]) + v * v * ((float(obs[p, pv0]) - float(obs[p, ik])) / x1
                                                - float(obs[p, ikr]))
        else:
            d0 = float(obs[p, iacc])
        z[0] = half * (vy + st[0])
        z[1] = vy - st[0]
        z[2] = half * (r + st[1])
        z[3] = r - st[1]
        z[4] = ey - st[2]
        z[5] = eyd - st[3]
        z[6] = (ep - st[4] + math.pi) % two_pi - math.pi
        z[7] = epd - st[5]
        z[8] = ey
        j = 9
        if n_out == 2:
            z[9] = ep
            j = 10
        z[j] = d0 - st[7]
        z[j + 1] = float(obs[p, ik])
        for q in range(pv1 - pv0):
            z[j + 2 + q] = float(obs[p, pv0 + q])
        z[width - 1] = float(obs[p, ikr])
        vc = min(max(v_x, speeds[0]), speeds[s_last + 1])
        i = np.searchsorted(speeds, vc, side="right") - 1
        i = 0 if i < 0 else (s_last if i > s_last else i)
        t = (vc - speeds[i]) / (speeds[i + 1] - speeds[i])
        acc = 0.0
        for c in range(width):
            acc += (tables[p, i, c] + t * slopes[p, i, c]) * z[c]
        du = -acc
        du = max_du if du > max_du else (-max_du if du < -max_du else du)
        u = st[6] + du
        u = max_steer if u > max_steer else (-max_steer if u < -max_steer else u)
        st[0], st[1], st[2], st[3], st[4], st[5] = vy, r, ey, eyd, ep, epd
        st[6] = u
        st[7] = d0
        st[8] = n_hold - 1.0
    a = st[6] * inv_steer
    return 1.0 if a > 1.0 else (-1.0 if a < -1.0 else a)


@njit(cache=True)
def _advance(i, k, action, arrays, max_steer, max_steps, dt, acc_buf, out) -> bool:
    """Apply ``action`` to car ``i`` for control step ``k`` (1-based), accumulate its fitness terms into
    ``out[i]`` (ITAE, last t|e_y|, max|a_y|, min F_z, steps, max|e_y|) and return True when its episode is over."""
    err, outputs, car, term = arrays.err, arrays.outputs, arrays.car, arrays.term
    arrays.actions[i] = action
    arrays.inputs[i, L.U_DELTA] = action * max_steer
    _step_one(i, arrays)
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


@njit(cache=True, parallel=True)
def rollout_smc(arrays, env_max_steer, lanes, max_steps, dt, idx, k, pole, eta_k, inv_layer, min_speed, v_star, guard,
                shift, inv_steer, acc_buf, out):
    """Whole episodes of every car under its own SMC gains (see the module docstring); ``out`` (n, 6).
    ``arrays``: the env's ``envs.kernels.SimArrays``; ``env_max_steer``: its road-wheel angle of action 1 [rad].
    ``lanes``: number of parallel lanes (the thread count); each lane runs a contiguous block of cars, so two
    threads never write the same cache line except at a block boundary (interleaved cars ran ~1.45x slower on
    2 threads from false sharing)."""
    obs = arrays.obs
    n = obs.shape[0]
    for lane in prange(lanes):
        for i in range(lane * n // lanes, (lane + 1) * n // lanes):
            for step in range(1, max_steps + 1):
                a = smc_action(i, obs, idx, k, pole, eta_k, inv_layer, min_speed, v_star, guard, shift, inv_steer)
                if _advance(i, step, a, arrays, env_max_steer, max_steps, dt, acc_buf, out):
                    break


@njit(cache=True, parallel=True)
def rollout_mpc(arrays, env_max_steer, lanes, max_steps, dt, idx, pv0, pv1, pv_vmin, pv_dt, preview, n_out, ts, n_hold,
                max_du, max_steer, speeds, tables, slopes, inv_steer, state, z, acc_buf, out):
    """Whole episodes of every car under its own MPC gain table; ``state`` (n, 9), ``z`` (n, width) scratch."""
    obs = arrays.obs
    n = obs.shape[0]
    for lane in prange(lanes):
        for i in range(lane * n // lanes, (lane + 1) * n // lanes):
            for step in range(1, max_steps + 1):
                a = mpc_action(i, obs, idx, pv0, pv1, pv_vmin, pv_dt, preview, n_out, ts, n_hold, max_du, max_steer,
                               speeds, tables, slopes, inv_steer, state, z[i])
                if _advance(i, step, a, arrays, env_max_steer, max_steps, dt, acc_buf, out):
                    break
