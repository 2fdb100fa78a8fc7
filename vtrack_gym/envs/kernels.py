"""Compiled env step: physics for every car, projection on its path, observation, termination.

One numba call per control period for all N cars (N = 1 for the single env), so the single and the vector
env run the same per-car code and give bit-identical results. Imported lazily by ``envs.sim``.

Track data of all paths in use are concatenated: ``tables`` (M, 8) with the column order of
``vtrack_gym.tracks.path`` and, per track k, ``t_start[k]``, ``t_n[k]`` (rows), ``t_ds[k]`` [m],
``t_len[k]`` [m], ``t_closed[k]`` (0/1), ``t_half_width[k]`` [m]; ``veh_track[i]`` is car i's track.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from vtrack_gym.baselines.pdflc_kernel import pdflc_step
from vtrack_gym.tracks.kernels import interp_row, project_point
from vtrack_gym.vehicle import layout as L
from vtrack_gym.vehicle.kernels import step_vehicle

# Column order of the track tables (see vtrack_gym.tracks.path).
C_X, C_Y, C_PSI, C_KAPPA, C_DKAPPA, C_Z, C_GRADE, C_ZPP = range(8)
N_COLS = 8

# Termination codes (names in ``TERMINATION_NAMES`` of envs.sim).
T_NONE, T_COMPLETED, T_OFF_ROAD, T_SPIN_OUT, T_WHEEL_LIFT, T_INVALID = range(6)

SPIN_HEADING_RAD = 0.5 * math.pi   # |e_phi| beyond this: spun out / driving the wrong way
SPIN_SIDESLIP_RAD = 0.3            # |atan(v_y / v_x)| beyond this above 3 m/s: spun out
# Reward configuration vector and reward-term columns (see envs.config.RewardConfig).
RW_ALIVE, RW_WEY, RW_EYSCALE, RW_WEPHI, RW_EPHISCALE, RW_WEFFORT, RW_WRATE, RW_FAIL, RW_COMPLETE = range(9)
N_TERMS = 6  # alive, tracking, heading, effort, rate, terminal
ERR_COLS = 6                       # s*, e_y, e_phi, kappa, s_dot, z of the projection
E_S, E_EY, E_EPHI, E_KAPPA, E_SDOT, E_Z = range(ERR_COLS)


@njit(cache=True)
def _wrap(a: float) -> float:
    """Angle wrapped to (-pi, pi]."""
    two_pi = 2.0 * math.pi
    w = a - two_pi * math.floor((a + math.pi) / two_pi)  # in [-pi, pi)
    return math.pi if w == -math.pi else w


@njit(cache=True)
def observe_one(i: int, state: np.ndarray, a_x: float, tables: np.ndarray, t_start: np.ndarray, t_n: np.ndarray,
                t_ds: np.ndarray, t_len: np.ndarray, t_closed: np.ndarray, veh_track: np.ndarray,
                s_prev: np.ndarray, progress: np.ndarray, v_ref: np.ndarray, window_m: float, first: bool,
                n_preview: int, preview_dt: float, preview_vmin: float, obs: np.ndarray, road: np.ndarray,
                err: np.ndarray, row: np.ndarray) -> None:
    """Project car ``i`` on its path and write its observation row, road inputs and error row."""
    k = veh_track[i]
    table = tables[t_start[k]:t_start[k] + t_n[k]]
    ds = t_ds[k]
    length = t_len[k]
    closed = t_closed[k] != 0
    x = state[L.S_X]
    y = state[L.S_Y]
    psi = state[L.S_PSI]
    vx = state[L.S_VX]
    vy = state[L.S_VY]
    r = state[L.S_R]

    s_guess = -1.0 if first else s_prev[i]
    s = project_point(table, ds, length, closed, x, y, s_guess, window_m)
    if first:
        progress[i] = 0.0
    else:
        step_s = s - s_prev[i]
        if closed:
            if step_s > 0.5 * length:
                step_s -= length
            elif step_s < -0.5 * length:
                step_s += length
        progress[i] += step_s
    s_prev[i] = s

    interp_row(table, ds, length, closed, s, row)
    psi_r = row[C_PSI]
    kappa = row[C_KAPPA]
    dkappa = row[C_DKAPPA]
    e_y = -(x - row[C_X]) * math.sin(psi_r) + (y - row[C_Y]) * math.cos(psi_r)
    e_phi = _wrap(psi - psi_r)
    sin_e = math.sin(e_phi)
    cos_e = math.cos(e_phi)
    denom = 1.0 - kappa * e_y
    if denom < 0.1:
        denom = 0.1
    s_dot = (vx * cos_e - vy * sin_e) / denom
    yaw_rate_ref = kappa * s_dot
    yaw_acc_ref = dkappa * s_dot * s_dot + kappa * a_x

    obs[i, 0] = e_y
    obs[i, 1] = e_phi
    obs[i, 2] = vx * sin_e + vy * cos_e
    obs[i, 3] = r - yaw_rate_ref
    obs[i, 4] = vx
    obs[i, 5] = vy
    obs[i, 6] = r
    obs[i, 7] = state[L.S_DELTA]
    obs[i, 8] = v_ref[i]
    obs[i, 9] = yaw_rate_ref
    obs[i, 10] = yaw_acc_ref
    obs[i, 11] = kappa
    obs[i, 12] = dkappa
    base = 13
    v_prev = vx if vx > preview_vmin else preview_vmin
    for j in range(n_preview):
        interp_row(table, ds, length, closed, s + v_prev * (j + 1) * preview_dt, row)
        obs[i, base + j] = row[C_KAPPA]

    # Road inputs for the next control period: grade and vertical acceleration v^2 z''(s) at the projection.
    interp_row(table, ds, length, closed, s, row)
    road[i, L.R_GRADE] = math.atan(row[C_GRADE])
    road[i, L.R_AZ] = vx * vx * row[C_ZPP]

    err[i, E_S] = s
    err[i, E_EY] = e_y
    err[i, E_EPHI] = e_phi
    err[i, E_KAPPA] = kappa
    err[i, E_SDOT] = s_dot
    err[i, E_Z] = row[C_Z]


@njit(cache=True)
def termination_one(i: int, state: np.ndarray, outputs: np.ndarray, err: np.ndarray, progress: np.ndarray,
                    t_len: np.ndarray, t_closed: np.ndarray, t_half_width: np.ndarray, veh_track: np.ndarray,
                    end_margin_m: float) -> int:
    """Termination code of car ``i`` after a step (``T_NONE`` if it goes on)."""
    for j in range(state.shape[0]):
        if not math.isfinite(state[j]):
            return T_INVALID
    for j in range(outputs.shape[0]):
        for w in range(L.O_FZFL, L.O_FZRR + 1):
            if outputs[j, w] <= 0.0:
                return T_WHEEL_LIFT
    k = veh_track[i]
    vx = state[L.S_VX]
    if abs(err[i, E_EPHI]) > SPIN_HEADING_RAD:
        return T_SPIN_OUT
    if vx > 3.0 and abs(math.atan2(state[L.S_VY], vx)) > SPIN_SIDESLIP_RAD:
        return T_SPIN_OUT
    if abs(err[i, E_EY]) > t_half_width[k]:
        return T_OFF_ROAD
    if t_closed[k] != 0:
        if progress[i] >= t_len[k]:
            return T_COMPLETED
    elif err[i, E_S] >= t_len[k] - end_margin_m:
        return T_COMPLETED
    return T_NONE


@njit(cache=True)
def reward_one(i: int, code: int, e_y: float, e_phi: float, action: float, prev_action: float, rw: np.ndarray,
               terms: np.ndarray) -> float:
    """Reward of car ``i`` for one step; its six terms go to ``terms[i]``."""
    q_ey = (e_y / rw[RW_EYSCALE]) ** 2
    q_ephi = (e_phi / rw[RW_EPHISCALE]) ** 2
    terms[i, 0] = rw[RW_ALIVE]
    terms[i, 1] = -rw[RW_WEY] * (q_ey if q_ey < 4.0 else 4.0)
    terms[i, 2] = -rw[RW_WEPHI] * (q_ephi if q_ephi < 4.0 else 4.0)
    terms[i, 3] = -rw[RW_WEFFORT] * action * action
    da = (action - prev_action) / 0.1
    terms[i, 4] = -rw[RW_WRATE] * da * da
    if code == T_COMPLETED:
        terms[i, 5] = rw[RW_COMPLETE]
    elif code != T_NONE:
        terms[i, 5] = rw[RW_FAIL]
    else:
        terms[i, 5] = 0.0
    return terms[i, 0] + terms[i, 1] + terms[i, 2] + terms[i, 3] + terms[i, 4] + terms[i, 5]


@njit(cache=True)
def _step_one(i: int, states: np.ndarray, inputs: np.ndarray, road: np.ndarray, params: np.ndarray,
              models: np.ndarray, dt: float, n_sub: int, outputs: np.ndarray, work: np.ndarray,
              tables: np.ndarray, t_start: np.ndarray, t_n: np.ndarray, t_ds: np.ndarray, t_len: np.ndarray,
              t_closed: np.ndarray, t_half_width: np.ndarray, veh_track: np.ndarray, s_prev: np.ndarray,
              progress: np.ndarray, v_ref: np.ndarray, n_preview: int, preview_dt: float, preview_vmin: float,
              end_margin_m: float, obs: np.ndarray, err: np.ndarray, term: np.ndarray, rows: np.ndarray,
              actions: np.ndarray, prev_actions: np.ndarray, rw: np.ndarray, terms: np.ndarray,
              reward: np.ndarray, pd_mem: np.ndarray, pd_gains: np.ndarray, pd_surface: np.ndarray,
              pd_kinks: bool) -> None:
    throttle, brake = pdflc_step(states[i, L.S_VX], v_ref[i], pd_mem[i], pd_gains, pd_surface, pd_kinks)
    inputs[i, L.U_THROTTLE] = throttle
    inputs[i, L.U_BRAKE] = brake
    step_vehicle(states[i], inputs[i], road[i], params[i], models[i], dt, n_sub, outputs[i], work[i])
    travel = abs(states[i, L.S_VX]) * dt * n_sub
    window = 5.0 + 3.0 * travel
    a_x = outputs[i, n_sub - 1, L.O_AX]
    observe_one(i, states[i], a_x, tables, t_start, t_n, t_ds, t_len, t_closed, veh_track, s_prev, progress,
                v_ref, window, False, n_preview, preview_dt, preview_vmin, obs, road, err, rows[i])
    term[i] = termination_one(i, states[i], outputs[i], err, progress, t_len, t_closed, t_half_width,
                              veh_track, end_margin_m)
    reward[i] = reward_one(i, term[i], err[i, E_EY], err[i, E_EPHI], actions[i], prev_actions[i], rw, terms)
    prev_actions[i] = actions[i]


@njit(cache=True)
def step_serial(states, inputs, road, params, models, dt, n_sub, outputs, work, tables, t_start, t_n,
                t_ds, t_len, t_closed, t_half_width, veh_track, s_prev, progress, v_ref, n_preview,
                preview_dt, preview_vmin, end_margin_m, obs, err, term, rows, actions, prev_actions, rw, terms,
                reward, pd_mem, pd_gains, pd_surface, pd_kinks) -> None:
    """One control period for every car, single-threaded."""
    for i in range(states.shape[0]):
        _step_one(i, states, inputs, road, params, models, dt, n_sub, outputs, work, tables, t_start, t_n,
                  t_ds, t_len, t_closed, t_half_width, veh_track, s_prev, progress, v_ref, n_preview,
                  preview_dt, preview_vmin, end_margin_m, obs, err, term, rows, actions, prev_actions, rw, terms,
                  reward, pd_mem, pd_gains, pd_surface, pd_kinks)


@njit(cache=True, parallel=True)
def step_parallel(states, inputs, road, params, models, dt, n_sub, outputs, work, tables, t_start, t_n,
                  t_ds, t_len, t_closed, t_half_width, veh_track, s_prev, progress, v_ref, n_preview,
                  preview_dt, preview_vmin, end_margin_m, obs, err, term, rows, actions, prev_actions, rw, terms,
                  reward, pd_mem, pd_gains, pd_surface, pd_kinks) -> None:
    """One control period for every car, cars spread over threads (same per-car code)."""
    for i in prange(states.shape[0]):
        _step_one(i, states, inputs, road, params, models, dt, n_sub, outputs, work, tables, t_start, t_n,
                  t_ds, t_len, t_closed, t_half_width, veh_track, s_prev, progress, v_ref, n_preview,
                  preview_dt, preview_vmin, end_margin_m, obs, err, term, rows, actions, prev_actions, rw, terms,
                  reward, pd_mem, pd_gains, pd_surface, pd_kinks)


@njit(cache=True)
def observe_indices(idx, states, a_x, tables, t_start, t_n, t_ds, t_len, t_closed, veh_track,
                    s_prev, progress, v_ref, n_preview, preview_dt, preview_vmin, obs, road, err, rows) -> None:
    """Fresh observation (global projection search, progress reset) for the cars in ``idx``."""
    for i in idx:
        observe_one(i, states[i], a_x[i], tables, t_start, t_n, t_ds, t_len, t_closed, veh_track, s_prev,
                    progress, v_ref, 0.0, True, n_preview, preview_dt, preview_vmin, obs, road, err, rows[i])
