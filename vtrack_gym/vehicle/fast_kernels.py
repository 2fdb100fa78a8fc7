"""The ``fast`` plant: the default nonlinear plant (``vehicle.kernels``) rewritten for SIMD, same model and RK4.

Structure of arrays: the cars are taken in blocks of ``BLOCK``; each block's state, RK4 stage, RK4 sum, per-car
constants and outputs sit in one flat scratch buffer, one row of ``BLOCK`` floats per variable, and every loop
runs over the cars of a block innermost. The derivative is branch-free (selects, min/max) and calls no library
function: sin/cos, atan2 and tanh are ``vehicle.fast_math``'s polynomial forms (bounded errors, about 1e-16), so
LLVM vectorises the whole derivative across cars (``benchmarks/bench_fast_plant.py`` lists the vector
instructions). Divisions by parameters are multiplications by reciprocals computed once per call, and the
friction ellipse times the effective load is one square root (``_wheel_lateral_scale``). The stage loops
(``rk4_block``) compile with IEEE division (no zero test per division: every denominator is positive) and
without array reference counting, and without fast-math: not even contraction into fused multiply-adds, which
LLVM may apply differently to the vector body and the scalar remainder; so the vector lanes and the scalar
remainder do the same operations and a car's trajectory does not depend on its batch
(``tests/test_fast_numerics.py``).

Agreement with the default plant: not bit-identical (rounding of the rewritten formulas and the approximations);
one control period from the same states within 1e-10 of each variable's scale, and closed-loop episodes within
the tolerances ``tests/test_fast_numerics.py`` states.
Cars of the ``linear`` model are stepped by the default kernel (their model has no transcendental cost to save).
"""

from __future__ import annotations

import numpy as np

from vtrack_gym._jit import kernel, prange
from vtrack_gym.vehicle import layout as L
from vtrack_gym.vehicle.fast_math import atan_ratio, sin_cos, tanh_bounded
from vtrack_gym.vehicle.kernels import WORKSPACE_SIZE, step_vehicle
from vtrack_gym.vehicle.params import GRAVITY_MPS2

_G = GRAVITY_MPS2
BLOCK = 32
"""Cars per structure-of-arrays block (its scratch, ``ROWS`` x ``BLOCK`` floats, stays in the L1 cache)."""

# Per-car constants of one call (rows of the block's K table).
(K_CMD, K_INV_TAU_S, K_RATE, K_FZF_ST, K_FZR_ST, K_LT, K_KROLL, K_CROLL, K_DF_ROLL, K_DR_ROLL, K_DF_AY, K_DR_AY,
 K_DRIVE, K_FDRIVE_MAX, K_PMAX, K_BRAKE, K_SD_F, K_SB_F, K_SD_R, K_SB_R, K_DRAG, K_ROLL_RES, K_GRADE_F, K_MU,
 K_INV_MU, K_A1, K_A2, K_B0F, K_B0R, K_CF, K_CR, K_DF, K_DR, K_EPS, K_INV_FZF0, K_INV_FZR0, K_INV_SIGMA,
 K_RELAX_ON, K_INV_M, K_INV_IZ, K_HALF_TW, K_VLO, K_VHI, K_INV_DV, K_INV_WB, K_A2_WB, K_INV_TAU_K, K_INV_TAU_LT,
 K_MSHS, K_INV_IROLL, K_AZ) = range(51)
N_K = 51
# Row offsets (in units of BLOCK) of the block's tables in the scratch buffer.
R_X = 0                       # state at the start of the physics step (N_STATE rows)
R_S = R_X + L.N_STATE         # RK4 stage state
R_ACC = R_S + L.N_STATE       # RK4 running sum k1 + 2 k2 + 2 k3
R_K = R_ACC + L.N_STATE       # per-car constants (N_K rows)
R_OUT = R_K + N_K             # outputs of the current physics step (N_OUTPUT rows)
ROWS = R_OUT + L.N_OUTPUT
WORK_COLUMNS = max(WORKSPACE_SIZE, ROWS)
"""Columns of the plant's scratch array in fast mode: a block's rows of it hold the block's tables (flat), and the
first ``WORKSPACE_SIZE`` of a car's row are the default kernel's scratch for a linear-model car."""


def workspace(n: int) -> np.ndarray:
    """The scratch array of ``n`` cars in fast mode: (``BLOCK`` x number of blocks, ``WORK_COLUMNS``) float64."""
    blocks = -(-n // BLOCK)
    return np.zeros((blocks * BLOCK, WORK_COLUMNS), dtype=np.float64)


@kernel(inline=True)
def _k(w: np.ndarray, row: int, i: int) -> float:
    return w[(R_K + row) * BLOCK + i]


@kernel(inline=True)
def _clip(v: float, lo: float, hi: float) -> float:
    return min(max(v, lo), hi)


@kernel(inline=True)
def _wheel_lateral_scale(fz: float, fx: float, inv_fz0: float, eps: float, inv_mu: float) -> float:
    """Effective load times friction ellipse of one wheel [N]: F_z (1 - eps (F_z/F_z0 - 1))^+ sqrt(1 - (F_x / (mu
    F_z))^2)^+ = (1 - eps (F_z/F_z0 - 1))^+ sqrt(F_z^2 - (F_x / mu)^2)^+, 0 for F_z <= 0."""
    load = max(1.0 - eps * (fz * inv_fz0 - 1.0), 0.0)
    fx_mu = fx * inv_mu
    ell = np.sqrt(max(fz * fz - fx_mu * fx_mu, 0.0))
    return load * ell if fz > 0.0 else 0.0


@kernel(inline=True)
def _pacejka(alpha: float, b0: float, c: float, d: float) -> float:
    """Normalised Pacejka shape mu D sin(C atan(B0 alpha)) (``d`` = mu D)."""
    s, _ = sin_cos(c * atan_ratio(b0 * alpha, 1.0))
    return d * s


@kernel(inline=True)
def _forces(w: np.ndarray, i: int, base: int) -> tuple:
    """Wheel loads, longitudinal and lateral forces of car ``i`` at the state in rows ``base``: (fz_fl, fz_fr,
    fz_rl, fz_rr, fx_fl, fx_fr, fx_rl, fx_rr, f_resist, fyf, fyr, dalpha_f, dalpha_r) [N, rad/s]."""
    vx = w[(base + L.S_VX) * BLOCK + i]
    vy = w[(base + L.S_VY) * BLOCK + i]
    r = w[(base + L.S_R) * BLOCK + i]
    axl = w[(base + L.S_AXL) * BLOCK + i]
    m_roll = (_k(w, K_KROLL, i) * w[(base + L.S_ROLL) * BLOCK + i]
              + _k(w, K_CROLL, i) * w[(base + L.S_ROLL_RATE) * BLOCK + i])
    ayl = w[(base + L.S_AYL) * BLOCK + i]
    d_f = _k(w, K_DF_ROLL, i) * m_roll + _k(w, K_DF_AY, i) * ayl
    d_r = _k(w, K_DR_ROLL, i) * m_roll + _k(w, K_DR_AY, i) * ayl
    fzf_axle = _k(w, K_FZF_ST, i) - _k(w, K_LT, i) * axl
    fzr_axle = _k(w, K_FZR_ST, i) + _k(w, K_LT, i) * axl
    fz_fl, fz_fr = 0.5 * fzf_axle - d_f, 0.5 * fzf_axle + d_f
    fz_rl, fz_rr = 0.5 * fzr_axle - d_r, 0.5 * fzr_axle + d_r
    f_drive = _k(w, K_DRIVE, i) * min(_k(w, K_FDRIVE_MAX, i), _k(w, K_PMAX, i) / max(vx, 1.0))
    sgn = tanh_bounded(vx * 10.0)
    f_brake = _k(w, K_BRAKE, i) * sgn
    fx_f = _k(w, K_SD_F, i) * f_drive - _k(w, K_SB_F, i) * f_brake
    fx_r = _k(w, K_SD_R, i) * f_drive - _k(w, K_SB_R, i) * f_brake
    f_resist = _k(w, K_DRAG, i) * vx * abs(vx) + _k(w, K_ROLL_RES, i) * sgn + _k(w, K_GRADE_F, i)
    mu = _k(w, K_MU, i)
    fx_fl = _clip(fx_f, -mu * max(fz_fl, 0.0), mu * max(fz_fl, 0.0))
    fx_fr = _clip(fx_f, -mu * max(fz_fr, 0.0), mu * max(fz_fr, 0.0))
    fx_rl = _clip(fx_r, -mu * max(fz_rl, 0.0), mu * max(fz_rl, 0.0))
    fx_rr = _clip(fx_r, -mu * max(fz_rr, 0.0), mu * max(fz_rr, 0.0))
    vxs = max(vx, 0.5)
    alpha_f = w[(base + L.S_DELTA) * BLOCK + i] - atan_ratio(vy + _k(w, K_A1, i) * r, vxs)
    alpha_r = -atan_ratio(vy - _k(w, K_A2, i) * r, vxs)
    relax = _k(w, K_RELAX_ON, i) != 0.0
    lag_f = w[(base + L.S_ALF) * BLOCK + i]
    lag_r = w[(base + L.S_ALR) * BLOCK + i]
    rate = vxs * _k(w, K_INV_SIGMA, i)
    dalpha_f = rate * (alpha_f - lag_f) if relax else 0.0
    dalpha_r = rate * (alpha_r - lag_r) if relax else 0.0
    shape_f = _pacejka(lag_f if relax else alpha_f, _k(w, K_B0F, i), _k(w, K_CF, i), _k(w, K_DF, i))
    shape_r = _pacejka(lag_r if relax else alpha_r, _k(w, K_B0R, i), _k(w, K_CR, i), _k(w, K_DR, i))
    eps, inv_mu = _k(w, K_EPS, i), _k(w, K_INV_MU, i)
    fyf = shape_f * (_wheel_lateral_scale(fz_fl, fx_fl, _k(w, K_INV_FZF0, i), eps, inv_mu)
                     + _wheel_lateral_scale(fz_fr, fx_fr, _k(w, K_INV_FZF0, i), eps, inv_mu))
    fyr = shape_r * (_wheel_lateral_scale(fz_rl, fx_rl, _k(w, K_INV_FZR0, i), eps, inv_mu)
                     + _wheel_lateral_scale(fz_rr, fx_rr, _k(w, K_INV_FZR0, i), eps, inv_mu))
    return fz_fl, fz_fr, fz_rl, fz_rr, fx_fl, fx_fr, fx_rl, fx_rr, f_resist, fyf, fyr, dalpha_f, dalpha_r


@kernel(inline=True)
def _body_rates(w: np.ndarray, i: int, base: int, f: tuple, sin_d: float, cos_d: float,
                ddelta: float) -> tuple[float, float, float]:
    """(v_x', v_y', r') of car ``i``: the dynamic single-track rates, blended with the kinematic model's below
    v_blend_hi (a select, not a branch)."""
    vx = w[(base + L.S_VX) * BLOCK + i]
    vy = w[(base + L.S_VY) * BLOCK + i]
    r = w[(base + L.S_R) * BLOCK + i]
    fx_fl, fx_fr, fx_rl, fx_rr, f_resist, fyf, fyr = f[4], f[5], f[6], f[7], f[8], f[9], f[10]
    fxf = fx_fl + fx_fr
    fxr = fx_rl + fx_rr
    inv_m = _k(w, K_INV_M, i)
    lat_f = fxf * sin_d + fyf * cos_d
    dvx = (fxf * cos_d - fyf * sin_d + fxr - f_resist) * inv_m + r * vy
    dvy = (lat_f + fyr) * inv_m - r * vx
    dr = (_k(w, K_A1, i) * lat_f - _k(w, K_A2, i) * fyr
          + _k(w, K_HALF_TW, i) * ((fx_fr - fx_fl) * cos_d + (fx_rr - fx_rl))) * _k(w, K_INV_IZ, i)
    inv_c = 1.0 / cos_d
    tan_d = sin_d * inv_c
    sec2 = inv_c * inv_c
    inv_wb, inv_tk = _k(w, K_INV_WB, i), _k(w, K_INV_TAU_K, i)
    a2_wb = _k(w, K_A2_WB, i)
    dvx_kin = (fxf * cos_d + fxr - f_resist) * inv_m
    dvy_kin = (dvx_kin * tan_d + vx * ddelta * sec2) * a2_wb + (vx * a2_wb * tan_d - vy) * inv_tk
    dr_kin = (dvx_kin * tan_d + vx * ddelta * sec2) * inv_wb + (vx * tan_d * inv_wb - r) * inv_tk
    wt = _clip((vx - _k(w, K_VLO, i)) * _k(w, K_INV_DV, i), 0.0, 1.0)
    wt = wt * wt * (3.0 - 2.0 * wt)
    dynamic = vx >= _k(w, K_VHI, i)
    dvx = dvx if dynamic else wt * dvx + (1.0 - wt) * dvx_kin
    dvy = dvy if dynamic else wt * dvy + (1.0 - wt) * dvy_kin
    dr = dr if dynamic else wt * dr + (1.0 - wt) * dr_kin
    return dvx, dvy, dr


@kernel(inline=True)
def _rates(w: np.ndarray, i: int, base: int) -> tuple:
    """The 13 state rates of car ``i`` at the state in rows ``base``, then a_x, a_y and the four F_z."""
    vx = w[(base + L.S_VX) * BLOCK + i]
    vy = w[(base + L.S_VY) * BLOCK + i]
    r = w[(base + L.S_R) * BLOCK + i]
    delta = w[(base + L.S_DELTA) * BLOCK + i]
    roll = w[(base + L.S_ROLL) * BLOCK + i]
    roll_rate = w[(base + L.S_ROLL_RATE) * BLOCK + i]
    ddelta = _clip((_k(w, K_CMD, i) - delta) * _k(w, K_INV_TAU_S, i), -_k(w, K_RATE, i), _k(w, K_RATE, i))
    f = _forces(w, i, base)
    sin_d, cos_d = sin_cos(delta)
    dvx, dvy, dr = _body_rates(w, i, base, f, sin_d, cos_d, ddelta)
    ax = dvx - r * vy
    ay = dvy + r * vx
    sin_roll, cos_roll = sin_cos(roll)
    droll_rate = (_k(w, K_MSHS, i) * (ay * cos_roll + _G * sin_roll) - _k(w, K_KROLL, i) * roll
                  - _k(w, K_CROLL, i) * roll_rate) * _k(w, K_INV_IROLL, i)
    sin_psi, cos_psi = sin_cos(w[(base + L.S_PSI) * BLOCK + i])
    inv_lt = _k(w, K_INV_TAU_LT, i)
    return (vx * cos_psi - vy * sin_psi, vx * sin_psi + vy * cos_psi, r, dvx, dvy, dr, roll_rate, droll_rate,
            ddelta, (ax - w[(base + L.S_AXL) * BLOCK + i]) * inv_lt, (ay - w[(base + L.S_AYL) * BLOCK + i]) * inv_lt,
            f[11], f[12], ax, ay, f[0], f[1], f[2], f[3])


@kernel(inline=True)
def _store(w: np.ndarray, i: int, k: int, dk: float, kind: int, c: float) -> None:
    """One state variable's RK4 bookkeeping for stage ``kind`` (0: k1, 1: k2 or k3, 2: k4): the running sum
    k1 + 2 k2 + 2 k3 (the default kernel's order), the next stage's state x + c k, or the new state."""
    x = w[(R_X + k) * BLOCK + i]
    acc = (R_ACC + k) * BLOCK + i
    if kind == 0:
        w[acc] = dk
        w[(R_S + k) * BLOCK + i] = x + c * dk
    elif kind == 1:
        w[acc] = w[acc] + 2.0 * dk
        w[(R_S + k) * BLOCK + i] = x + c * dk
    else:
        w[(R_X + k) * BLOCK + i] = x + c * (w[acc] + dk)


@kernel(inline=True)
def _store_all(w: np.ndarray, i: int, d: tuple, kind: int, c: float) -> None:
    """``_store`` of the 13 state rates ``d[0:13]`` (``kind`` a literal at every call: the branches fold)."""
    _store(w, i, L.S_X, d[0], kind, c)
    _store(w, i, L.S_Y, d[1], kind, c)
    _store(w, i, L.S_PSI, d[2], kind, c)
    _store(w, i, L.S_VX, d[3], kind, c)
    _store(w, i, L.S_VY, d[4], kind, c)
    _store(w, i, L.S_R, d[5], kind, c)
    _store(w, i, L.S_ROLL, d[6], kind, c)
    _store(w, i, L.S_ROLL_RATE, d[7], kind, c)
    _store(w, i, L.S_DELTA, d[8], kind, c)
    _store(w, i, L.S_AXL, d[9], kind, c)
    _store(w, i, L.S_AYL, d[10], kind, c)
    _store(w, i, L.S_ALF, d[11], kind, c)
    _store(w, i, L.S_ALR, d[12], kind, c)


@kernel(error_model="numpy", refcount=False)
def rk4_block(w: np.ndarray, nb: int, dt: float) -> None:
    """One RK4 step of ``dt`` [s] of the ``nb`` cars of the block in ``w`` (flat scratch); the outputs at the step's
    start go to the block's output rows. Four loops over the cars (one per stage), each vectorised."""
    half = 0.5 * dt
    for i in range(nb):
        d = _rates(w, i, R_X)
        _store_all(w, i, d, 0, half)
        w[(R_OUT + L.O_AX) * BLOCK + i] = d[13]
        w[(R_OUT + L.O_AY) * BLOCK + i] = d[14]
        w[(R_OUT + L.O_AZ) * BLOCK + i] = _k(w, K_AZ, i)
        w[(R_OUT + L.O_FZFL) * BLOCK + i] = d[15]
        w[(R_OUT + L.O_FZFR) * BLOCK + i] = d[16]
        w[(R_OUT + L.O_FZRL) * BLOCK + i] = d[17]
        w[(R_OUT + L.O_FZRR) * BLOCK + i] = d[18]
    for i in range(nb):
        _store_all(w, i, _rates(w, i, R_S), 1, half)
    for i in range(nb):
        _store_all(w, i, _rates(w, i, R_S), 1, dt)
    dt6 = dt / 6.0
    for i in range(nb):
        _store_all(w, i, _rates(w, i, R_S), 2, dt6)


@kernel(inline=True)
def _put(w: np.ndarray, row: int, i: int, value: float) -> None:
    w[(R_K + row) * BLOCK + i] = value


@kernel
def _pack_car(w: np.ndarray, c: int, x: np.ndarray, u: np.ndarray, road: np.ndarray, p: np.ndarray) -> None:
    """Column ``c`` of the block: car's state, and its constants of this call (inputs clipped as the default
    kernel clips them; reciprocals of the parameters it divides by)."""
    for k in range(L.N_STATE):
        w[(R_X + k) * BLOCK + c] = x[k]
    m, a1, a2, wb, tw, mu = p[L.P_M], p[L.P_A1], p[L.P_A2], p[L.P_L], p[L.P_TRACK], p[L.P_MU]
    cmd = _clip(u[L.U_DELTA], -p[L.P_DELTA_MAX], p[L.P_DELTA_MAX])
    tau_s = p[L.P_TAU_STEER]
    if tau_s <= 0.0:
        w[(R_X + L.S_DELTA) * BLOCK + c] = cmd
    fz_total = m * (_G * np.cos(road[L.R_GRADE]) + road[L.R_AZ])
    share, share_d, share_b = p[L.P_ROLL_SHARE_F], p[L.P_DRIVE_SHARE_F], p[L.P_BRAKE_SHARE_F]
    sigma = p[L.P_RELAX]
    _put(w, K_CMD, c, cmd)
    _put(w, K_INV_TAU_S, c, 1.0 / tau_s if tau_s > 0.0 else 0.0)
    _put(w, K_RATE, c, p[L.P_DELTA_RATE] if tau_s > 0.0 else 0.0)
    _put(w, K_FZF_ST, c, fz_total * a2 / wb)
    _put(w, K_FZR_ST, c, fz_total * a1 / wb)
    _put(w, K_LT, c, m * p[L.P_HCG] / wb)
    _put(w, K_KROLL, c, p[L.P_KROLL])
    _put(w, K_CROLL, c, p[L.P_CROLL])
    _put(w, K_DF_ROLL, c, share / tw)
    _put(w, K_DR_ROLL, c, (1.0 - share) / tw)
    _put(w, K_DF_AY, c, p[L.P_LT_DIRECT_F] / tw)
    _put(w, K_DR_AY, c, p[L.P_LT_DIRECT_R] / tw)
    _put(w, K_DRIVE, c, _clip(u[L.U_THROTTLE], 0.0, 1.0))
    _put(w, K_FDRIVE_MAX, c, p[L.P_FDRIVE_MAX])
    _put(w, K_PMAX, c, p[L.P_PMAX])
    _put(w, K_BRAKE, c, p[L.P_BRAKE_GAIN] * _clip(u[L.U_BRAKE], 0.0, p[L.P_PEDAL_MAX]))
    _put(w, K_SD_F, c, 0.5 * share_d)
    _put(w, K_SB_F, c, 0.5 * share_b)
    _put(w, K_SD_R, c, 0.5 * (1.0 - share_d))
    _put(w, K_SB_R, c, 0.5 * (1.0 - share_b))
    _put(w, K_DRAG, c, p[L.P_DRAG_K])
    _put(w, K_ROLL_RES, c, p[L.P_FROLL] * fz_total)
    _put(w, K_GRADE_F, c, m * _G * np.sin(road[L.R_GRADE]))
    _put(w, K_MU, c, mu)
    _put(w, K_INV_MU, c, 1.0 / mu)
    _put(w, K_A1, c, a1)
    _put(w, K_A2, c, a2)
    _put(w, K_B0F, c, p[L.P_B0F])
    _put(w, K_B0R, c, p[L.P_B0R])
    _put(w, K_CF, c, p[L.P_SHAPE_CF])
    _put(w, K_CR, c, p[L.P_SHAPE_CR])
    _put(w, K_DF, c, mu * p[L.P_PEAK_DF])
    _put(w, K_DR, c, mu * p[L.P_PEAK_DR])
    _put(w, K_EPS, c, p[L.P_LOAD_SENS])
    _put(w, K_INV_FZF0, c, 1.0 / (0.5 * m * _G * a2 / wb))
    _put(w, K_INV_FZR0, c, 1.0 / (0.5 * m * _G * a1 / wb))
    _put(w, K_INV_SIGMA, c, 1.0 / sigma if sigma > 0.0 else 0.0)
    _put(w, K_RELAX_ON, c, 1.0 if sigma > 0.0 else 0.0)
    _put(w, K_INV_M, c, 1.0 / m)
    _put(w, K_INV_IZ, c, 1.0 / p[L.P_IZ])
    _put(w, K_HALF_TW, c, 0.5 * tw)
    _put(w, K_VLO, c, p[L.P_VBLEND_LO])
    _put(w, K_VHI, c, p[L.P_VBLEND_HI])
    _put(w, K_INV_DV, c, 1.0 / (p[L.P_VBLEND_HI] - p[L.P_VBLEND_LO]))
    _put(w, K_INV_WB, c, 1.0 / wb)
    _put(w, K_A2_WB, c, a2 / wb)
    _put(w, K_INV_TAU_K, c, 1.0 / p[L.P_TAU_KIN])
    _put(w, K_INV_TAU_LT, c, 1.0 / p[L.P_TAU_LT])
    _put(w, K_MSHS, c, p[L.P_MS] * p[L.P_HS])
    _put(w, K_INV_IROLL, c, 1.0 / p[L.P_IROLL])
    _put(w, K_AZ, c, road[L.R_AZ])


@kernel
def _schedule_command(w: np.ndarray, c: int, cmd: float, p: np.ndarray) -> None:
    """A late steering command [rad] taking over within the period (``envs.latency``), clipped like the default
    kernel's; with an ideal actuator (tau = 0) the road-wheel angle jumps to it."""
    cmd = _clip(cmd, -p[L.P_DELTA_MAX], p[L.P_DELTA_MAX])
    _put(w, K_CMD, c, cmd)
    if p[L.P_TAU_STEER] <= 0.0:
        w[(R_X + L.S_DELTA) * BLOCK + c] = cmd


@kernel
def advance_block(states: np.ndarray, inputs: np.ndarray, road: np.ndarray, params: np.ndarray,
                  models: np.ndarray, dt: float, n_sub: int, outputs: np.ndarray, work: np.ndarray,
                  cmds: np.ndarray, flags: np.ndarray, col: int, block: int) -> None:
    """Advance the cars of block ``block`` by ``n_sub`` RK4 steps of ``dt`` [s]; a car with ``flags[i, col]`` != 0
    (scheduled, ``envs.latency``) takes ``cmds[i, j]`` as its steering command in physics step j (and keeps the
    last in ``inputs``)."""
    scheduled = flags[:, col]
    lo = block * BLOCK
    nb = min(BLOCK, states.shape[0] - lo)
    w = work[lo:lo + BLOCK].reshape(-1)
    any_scheduled = False
    for c in range(nb):
        _pack_car(w, c, states[lo + c], inputs[lo + c], road[lo + c], params[lo + c])
        any_scheduled = any_scheduled or scheduled[lo + c] != 0.0
    for j in range(n_sub):
        if any_scheduled:
            for c in range(nb):
                if scheduled[lo + c] != 0.0:
                    _schedule_command(w, c, cmds[lo + c, j], params[lo + c])
        rk4_block(w, nb, dt)
        for c in range(nb):
            for o in range(L.N_OUTPUT):
                outputs[lo + c, j, o] = w[(R_OUT + o) * BLOCK + c]
    for c in range(nb):
        i = lo + c
        if models[i] != L.MODEL_LINEAR:
            for k in range(L.N_STATE):
                states[i, k] = w[(R_X + k) * BLOCK + c]
            if scheduled[i] != 0.0:
                inputs[i, L.U_DELTA] = cmds[i, n_sub - 1]
    for c in range(nb):  # after the unpacking: the default kernel's scratch of car i overlaps the block's tables
        if models[lo + c] == L.MODEL_LINEAR:
            _step_default(states, inputs, road, params, models, dt, n_sub, outputs, work, cmds, scheduled, lo + c)


@kernel
def _step_default(states: np.ndarray, inputs: np.ndarray, road: np.ndarray, params: np.ndarray,
                  models: np.ndarray, dt: float, n_sub: int, outputs: np.ndarray, work: np.ndarray,
                  cmds: np.ndarray, scheduled: np.ndarray, i: int) -> None:
    """Car ``i`` by the default kernel (a linear-model car), with its scheduled commands as the env steps them."""
    if scheduled[i] != 0.0:
        for j in range(n_sub):
            inputs[i, L.U_DELTA] = cmds[i, j]
            step_vehicle(states[i], inputs[i], road[i], params[i], models[i], dt, 1, outputs[i, j:j + 1], work[i])
    else:
        step_vehicle(states[i], inputs[i], road[i], params[i], models[i], dt, n_sub, outputs[i], work[i])


@kernel
def step_batch_fast(states: np.ndarray, inputs: np.ndarray, road: np.ndarray, params: np.ndarray,
                    models: np.ndarray, dt: float, n_sub: int, outputs: np.ndarray, work: np.ndarray,
                    cmds: np.ndarray, flags: np.ndarray, col: int) -> None:
    """Advance every car by one control period, block after block (single thread). ``work``: ``workspace(n)``;
    ``cmds``, ``flags``, ``col``: the latency schedule (``advance_block``)."""
    for b in range(-(-states.shape[0] // BLOCK)):
        advance_block(states, inputs, road, params, models, dt, n_sub, outputs, work, cmds, flags, col, b)


@kernel(parallel=True)
def step_batch_fast_parallel(states: np.ndarray, inputs: np.ndarray, road: np.ndarray, params: np.ndarray,
                             models: np.ndarray, dt: float, n_sub: int, outputs: np.ndarray, work: np.ndarray,
                             cmds: np.ndarray, flags: np.ndarray, col: int) -> None:
    """``step_batch_fast`` with the blocks spread over threads (same per-block code, same results)."""
    for b in prange(-(-states.shape[0] // BLOCK)):
        advance_block(states, inputs, road, params, models, dt, n_sub, outputs, work, cmds, flags, col, b)
