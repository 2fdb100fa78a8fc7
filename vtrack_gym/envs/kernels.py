"""Compiled env step: physics for every car, projection on its path, observation, termination.

One numba call per control period for all N cars (N = 1 for the single env), so the single and the vector
env run the same per-car code and give bit-identical results. Imported lazily by ``envs.sim``.

Track data of all paths in use are concatenated: ``tables`` (M, 8) with the column order of
``vtrack_gym.tracks.path``; ``tmeta`` (K, 6) holds per track k its first row, row count, spacing [m],
length [m], closed flag (0/1) and half width [m]; ``veh_track[i]`` is car i's track.
Constant settings travel in one vector ``cfg`` (``CFG_*`` offsets), per-car scalars in ``car`` (n, 6)
(``CAR_*`` columns) so that the compiled call unboxes few arguments (the single env's hot path).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from vtrack_gym.envs.pdflc_kernel import pdflc_step
from vtrack_gym.tracks.kernels import interp_row, project_point
from vtrack_gym.vehicle import layout as L
from vtrack_gym.vehicle.kernels import step_vehicle

# Column order of the track tables (see vtrack_gym.tracks.path).
C_X, C_Y, C_PSI, C_KAPPA, C_DKAPPA, C_Z, C_GRADE, C_ZPP = range(8)
N_COLS = 8

# Track metadata columns, per-car scalar columns, and offsets in the constant settings vector.
TM_START, TM_N, TM_DS, TM_LEN, TM_CLOSED, TM_HALF_WIDTH = range(6)
CAR_S_PREV, CAR_PROGRESS, CAR_V_REF, CAR_PREV_ACTION, CAR_REWARD, CAR_MIN_FZ = range(6)
N_CAR = 6
(CFG_DT, CFG_NSUB, CFG_NPREV, CFG_PREV_DT, CFG_PREV_VMIN, CFG_END_MARGIN, CFG_KINKS, CFG_STEER_MAX) = range(8)
CFG_REWARD = 8   # 9 reward settings (RW_*) start here
N_CFG = 17

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
def observe_one(i: int, state: np.ndarray, a_x: float, tables: np.ndarray, tmeta: np.ndarray,
                veh_track: np.ndarray, car: np.ndarray, window_m: float, first: bool, cfg: np.ndarray,
                obs: np.ndarray, road: np.ndarray, err: np.ndarray, row: np.ndarray) -> None:
    """Project car ``i`` on its path and write its observation row, road inputs and error row."""
    k = veh_track[i]
    start = int(tmeta[k, TM_START])
    table = tables[start:start + int(tmeta[k, TM_N])]
    ds = tmeta[k, TM_DS]
    length = tmeta[k, TM_LEN]
    closed = tmeta[k, TM_CLOSED] != 0.0
    n_preview = int(cfg[CFG_NPREV])
    preview_dt = cfg[CFG_PREV_DT]
    preview_vmin = cfg[CFG_PREV_VMIN]
    x = state[L.S_X]
    y = state[L.S_Y]
    psi = state[L.S_PSI]
    vx = state[L.S_VX]
    vy = state[L.S_VY]
    r = state[L.S_R]

    s_guess = -1.0 if first else car[i, CAR_S_PREV]
    s = project_point(table, ds, length, closed, x, y, s_guess, window_m)
    if first:
        car[i, CAR_PROGRESS] = 0.0
    else:
        step_s = s - car[i, CAR_S_PREV]
        if closed:
            if step_s > 0.5 * length:
                step_s -= length
            elif step_s < -0.5 * length:
                step_s += length
        car[i, CAR_PROGRESS] += step_s
    car[i, CAR_S_PREV] = s

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
    obs[i, 8] = car[i, CAR_V_REF]
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
def termination_one(i: int, state: np.ndarray, outputs: np.ndarray, err: np.ndarray, car: np.ndarray,
                    tmeta: np.ndarray, veh_track: np.ndarray, end_margin_m: float) -> int:
    """Termination code of car ``i`` after a step (``T_NONE`` if it goes on); stores its min wheel load."""
    for j in range(state.shape[0]):
        if not math.isfinite(state[j]):
            return T_INVALID
    min_fz = math.inf
    for j in range(outputs.shape[0]):
        for w in range(L.O_FZFL, L.O_FZRR + 1):
            if outputs[j, w] < min_fz:
                min_fz = outputs[j, w]
    car[i, CAR_MIN_FZ] = min_fz
    if min_fz <= 0.0:
        return T_WHEEL_LIFT
    k = veh_track[i]
    vx = state[L.S_VX]
    if abs(err[i, E_EPHI]) > SPIN_HEADING_RAD:
        return T_SPIN_OUT
    if vx > 3.0 and abs(math.atan2(state[L.S_VY], vx)) > SPIN_SIDESLIP_RAD:
        return T_SPIN_OUT
    if abs(err[i, E_EY]) > tmeta[k, TM_HALF_WIDTH]:
        return T_OFF_ROAD
    if tmeta[k, TM_CLOSED] != 0.0:
        if car[i, CAR_PROGRESS] >= tmeta[k, TM_LEN]:
            return T_COMPLETED
    elif err[i, E_S] >= tmeta[k, TM_LEN] - end_margin_m:
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
              models: np.ndarray, outputs: np.ndarray, work: np.ndarray, tables: np.ndarray, tmeta: np.ndarray,
              veh_track: np.ndarray, car: np.ndarray, cfg: np.ndarray, obs: np.ndarray, err: np.ndarray,
              term: np.ndarray, rows: np.ndarray, actions: np.ndarray, terms: np.ndarray, pd_mem: np.ndarray,
              pd_gains: np.ndarray, pd_surface: np.ndarray) -> None:
    """One control period of car ``i``: speed loop, physics, projection, observation, termination, reward."""
    dt = cfg[CFG_DT]
    n_sub = int(cfg[CFG_NSUB])
    throttle, brake = pdflc_step(states[i, L.S_VX], car[i, CAR_V_REF], pd_mem[i], pd_gains[i], pd_surface,
                                 cfg[CFG_KINKS] != 0.0)
    inputs[i, L.U_THROTTLE] = throttle
    inputs[i, L.U_BRAKE] = brake
    step_vehicle(states[i], inputs[i], road[i], params[i], models[i], dt, n_sub, outputs[i], work[i])
    travel = abs(states[i, L.S_VX]) * dt * n_sub
    window = 5.0 + 3.0 * travel
    a_x = outputs[i, n_sub - 1, L.O_AX]
    observe_one(i, states[i], a_x, tables, tmeta, veh_track, car, window, False, cfg, obs, road, err, rows[i])
    code = termination_one(i, states[i], outputs[i], err, car, tmeta, veh_track, cfg[CFG_END_MARGIN])
    term[i] = code
    car[i, CAR_REWARD] = reward_one(i, code, err[i, E_EY], err[i, E_EPHI], actions[i], car[i, CAR_PREV_ACTION],
                                    cfg[CFG_REWARD:CFG_REWARD + 9], terms)
    car[i, CAR_PREV_ACTION] = actions[i]


@njit(cache=True)
def step_serial(states, inputs, road, params, models, outputs, work, tables, tmeta, veh_track, car,
                cfg, obs, err, term, rows, actions, terms, pd_mem, pd_gains, pd_surface) -> None:
    """One control period for every car, single-threaded."""
    for i in range(states.shape[0]):
        _step_one(i, states, inputs, road, params, models, outputs, work, tables, tmeta, veh_track, car, cfg, obs,
                  err, term, rows, actions, terms, pd_mem, pd_gains, pd_surface)


@njit(cache=True, parallel=True)
def step_parallel(states, inputs, road, params, models, outputs, work, tables, tmeta, veh_track, car,
                  cfg, obs, err, term, rows, actions, terms, pd_mem, pd_gains, pd_surface) -> None:
    """One control period for every car, cars spread over threads (same per-car code)."""
    for i in prange(states.shape[0]):
        _step_one(i, states, inputs, road, params, models, outputs, work, tables, tmeta, veh_track, car, cfg, obs,
                  err, term, rows, actions, terms, pd_mem, pd_gains, pd_surface)


@njit(cache=True)
def observe_indices(idx, states, tables, tmeta, veh_track, car, cfg, obs, road, err, rows) -> None:
    """Fresh observation (global projection search, progress reset) for the cars in ``idx`` (a_x = 0)."""
    for i in idx:
        observe_one(i, states[i], 0.0, tables, tmeta, veh_track, car, 0.0, True, cfg, obs, road, err, rows[i])
