"""Compiled (numba) vehicle dynamics: one implementation for N vehicles, N = 1 included.

Imported lazily (``vtrack_gym.vehicle.plant`` imports it on first use) so that ``import vtrack_gym`` stays
fast. All functions are ``cache=True`` and compiled without fastmath, so every vehicle of a batch follows
exactly the same IEEE operations as a single vehicle: batched and single runs are bit-identical.

Models (selected per vehicle by an integer id, see ``layout.MODEL_IDS``):

``nonlinear`` (default plant)
    Single-track lateral/yaw dynamics with per-wheel normal loads; normalised Pacejka lateral tyres
    ``F_y = mu D g(F_z) sin(C atan(B0 alpha))`` with the degressive effective load
    ``g(F_z) = F_z (1 - eps (F_z/F_z0 - 1))``, so that each wheel's slope at the static load F_z0 equals the
    paper's C_af/2, C_ar/2 and both the cornering stiffness and the peak force grow less than linearly with
    load (which is what makes load transfer matter), times a friction ellipse against the longitudinal
    force; longitudinal load transfer ``m a_x h / l`` with the whole car's CG height h, and lateral load
    transfer per axle from the roll spring/damper moment (front share), the sprung mass that axle carries at
    the roll centre ``m_s,axle a_y h_rc / t`` and the axle's unsprung mass at the wheel centres
    ``m_u,axle a_y h_u / t``; at steady state the total is the rigid-body ``m a_y h / t`` plus the lateral shift
    of the rolled sprung mass ``m_s g h_s sin(phi) / t``. A roll degree of freedom of the sprung mass about the
    roll axis; steering actuator (first-order lag with rate limit);
    front-wheel drive limited by power and traction; brakes split front/rear; aerodynamic drag; rolling
    resistance; road grade and road vertical acceleration; blend to the kinematic single-track model
    between ``v_blend_lo`` and ``v_blend_hi`` so standstill is regular. No wheel-spin degree of freedom:
    drive/brake forces act at the contact patch, capped at mu F_z per wheel (documented simplification).
``linear``
    The paper's eq. (5) exactly (paper-math section 2.2): linear axle tyres, small angles, the lateral and yaw
    rows with v_x as a parameter (clamped to >= 1 m/s in the divisions, where the design model is singular),
    and v_x' = sum F_x / m + r v_y. No roll; normal loads reported quasi-statically.

Integration: classic RK4 at a fixed physics step ``dt`` with inputs held over the control period.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from vtrack_gym.vehicle import layout as L
from vtrack_gym.vehicle.params import GRAVITY_MPS2

_G = GRAVITY_MPS2  # short name for the formulas; numba freezes it as a compile-time constant
_V_SIGN_EPS = 0.1      # [m/s] speed scale of the smooth sign used by brakes and rolling resistance
_V_DYN_MIN = 0.5       # [m/s] floor of v_x inside slip angles (the dynamic model's weight is 0 there)
_V_LIN_MIN = 1.0       # [m/s] floor of v_x in the linear model's divisions


@njit(cache=True)
def _clip(v: float, lo: float, hi: float) -> float:
    return lo if v < lo else (hi if v > hi else v)


@njit(cache=True)
def _load_factor(fz: float, fz0: float, eps: float) -> float:
    """Effective load of a wheel [N]: F_z (1 - eps (F_z/F_z0 - 1)), degressive, >= 0."""
    if fz <= 0.0:
        return 0.0
    g = fz * (1.0 - eps * (fz / fz0 - 1.0))
    return g if g > 0.0 else 0.0


@njit(cache=True)
def _ellipse(fx: float, fz: float, mu: float) -> float:
    """Friction-ellipse derating sqrt(1 - (F_x / (mu F_z))^2) of a wheel's lateral force."""
    if fz <= 0.0:
        return 0.0
    ratio = fx / (mu * fz)
    rem = 1.0 - ratio * ratio
    return math.sqrt(rem) if rem > 0.0 else 0.0


@njit(cache=True)
def _relaxed_slip(alpha: float, alpha_lag: float, vx: float, sigma: float) -> tuple[float, float]:
    """Slip angle [rad] the tyre force sees and d(alpha_lag)/dt [rad/s]: with a relaxation length ``sigma`` [m] > 0
    the lagged angle, which follows ``alpha`` with the time constant sigma / |v_x|; with 0 ``alpha`` itself."""
    if sigma <= 0.0:
        return alpha, 0.0
    return alpha_lag, abs(vx) / sigma * (alpha - alpha_lag)


@njit(cache=True)
def _derivatives(x: np.ndarray, cmd: float, throttle: float, pedal: float, cos_g: float, sin_g: float,
                 az_road: float, p: np.ndarray, model: int, dx: np.ndarray, out: np.ndarray) -> None:
    """Time derivative ``dx`` of state ``x`` for inputs already clipped to their ranges.

    ``cmd`` road-wheel command [rad], ``throttle`` [0..1], ``pedal`` brake pedal force [N], road grade as
    cos/sin, ``az_road`` [m/s^2]. ``out`` receives a_x, a_y, a_z [m/s^2] and the four F_z [N].
    """
    m = p[L.P_M]
    iz = p[L.P_IZ]
    a1 = p[L.P_A1]
    a2 = p[L.P_A2]
    wb = p[L.P_L]
    h = p[L.P_HCG]
    tw = p[L.P_TRACK]
    mu = p[L.P_MU]

    psi = x[L.S_PSI]
    vx = x[L.S_VX]
    vy = x[L.S_VY]
    r = x[L.S_R]
    roll = x[L.S_ROLL]
    roll_rate = x[L.S_ROLL_RATE]
    delta = x[L.S_DELTA]
    ax_lag = x[L.S_AXL]
    ay_lag = x[L.S_AYL]

    # Steering actuator: first-order lag with rate limit (tau = 0: ideal, handled by the stepper).
    tau_s = p[L.P_TAU_STEER]
    if tau_s > 0.0:
        rate = p[L.P_DELTA_RATE]
        ddelta = _clip((cmd - delta) / tau_s, -rate, rate)
    else:
        ddelta = 0.0

    # Normal loads: static + longitudinal transfer (lagged a_x) + lateral transfer.
    fz_total = m * (_G * cos_g + az_road)
    fzf_axle = fz_total * a2 / wb - m * ax_lag * h / wb
    fzr_axle = fz_total * a1 / wb + m * ax_lag * h / wb
    if model == L.MODEL_LINEAR:
        d_f = m * ay_lag * h * (a2 / wb) / tw
        d_r = m * ay_lag * h * (a1 / wb) / tw
    else:
        m_roll = p[L.P_KROLL] * roll + p[L.P_CROLL] * roll_rate
        share = p[L.P_ROLL_SHARE_F]
        d_f = (share * m_roll + ay_lag * p[L.P_LT_DIRECT_F]) / tw
        d_r = ((1.0 - share) * m_roll + ay_lag * p[L.P_LT_DIRECT_R]) / tw
    fz_fl = 0.5 * fzf_axle - d_f
    fz_fr = 0.5 * fzf_axle + d_f
    fz_rl = 0.5 * fzr_axle - d_r
    fz_rr = 0.5 * fzr_axle + d_r

    # Longitudinal wheel forces: power-limited drive, brakes with a smooth sign at standstill.
    v_pos = vx if vx > 1.0 else 1.0
    f_drive = throttle * min(p[L.P_FDRIVE_MAX], p[L.P_PMAX] / v_pos)
    # tanh(x) rounds to exactly +-1.0 for |x| > 19.1, so the shortcut is bit-identical.
    sgn = math.tanh(vx / _V_SIGN_EPS) if abs(vx) < 2.0 else (1.0 if vx > 0.0 else -1.0)
    f_brake = p[L.P_BRAKE_GAIN] * pedal * sgn
    share_d = p[L.P_DRIVE_SHARE_F]
    share_b = p[L.P_BRAKE_SHARE_F]
    fx_f_each = 0.5 * (share_d * f_drive - share_b * f_brake)
    fx_r_each = 0.5 * ((1.0 - share_d) * f_drive - (1.0 - share_b) * f_brake)
    f_resist = p[L.P_DRAG_K] * vx * abs(vx) + p[L.P_FROLL] * fz_total * sgn + m * _G * sin_g

    cos_d = math.cos(delta)
    sin_d = math.sin(delta)
    dalpha_f = 0.0
    dalpha_r = 0.0

    if model == L.MODEL_LINEAR:
        vxs = vx if vx > _V_LIN_MIN else _V_LIN_MIN
        fyf = p[L.P_CF] * (delta - (vy + a1 * r) / vxs)
        fyr = -p[L.P_CR] * (vy - a2 * r) / vxs
        fxf = 2.0 * fx_f_each
        fxr = 2.0 * fx_r_each
        dvx = (fxf * cos_d - fyf * sin_d + fxr - f_resist) / m + r * vy
        dvy = (fyf + fyr) / m - r * vxs
        dr = (a1 * fyf - a2 * fyr) / iz
        droll = 0.0
        droll_rate = 0.0
        ax = dvx - r * vy
        ay = dvy + r * vxs
    else:
        # Friction caps per wheel (no wheel-spin DOF).
        fx_fl = _clip(fx_f_each, -mu * max(fz_fl, 0.0), mu * max(fz_fl, 0.0))
        fx_fr = _clip(fx_f_each, -mu * max(fz_fr, 0.0), mu * max(fz_fr, 0.0))
        fx_rl = _clip(fx_r_each, -mu * max(fz_rl, 0.0), mu * max(fz_rl, 0.0))
        fx_rr = _clip(fx_r_each, -mu * max(fz_rr, 0.0), mu * max(fz_rr, 0.0))
        fxf = fx_fl + fx_fr
        fxr = fx_rl + fx_rr

        vxs = vx if vx > _V_DYN_MIN else _V_DYN_MIN
        alpha_f = delta - math.atan2(vy + a1 * r, vxs)
        alpha_r = -math.atan2(vy - a2 * r, vxs)
        alpha_f, dalpha_f = _relaxed_slip(alpha_f, x[L.S_ALF], vxs, p[L.P_RELAX])
        alpha_r, dalpha_r = _relaxed_slip(alpha_r, x[L.S_ALR], vxs, p[L.P_RELAX])
        # Pacejka shape once per axle; each wheel scales it by its effective load and friction ellipse.
        fz_f0 = 0.5 * m * _G * a2 / wb  # static load of one wheel on flat ground (B0's reference)
        fz_r0 = 0.5 * m * _G * a1 / wb
        eps = p[L.P_LOAD_SENS]
        shape_f = mu * p[L.P_PEAK_DF] * math.sin(p[L.P_SHAPE_CF] * math.atan(p[L.P_B0F] * alpha_f))
        shape_r = mu * p[L.P_PEAK_DR] * math.sin(p[L.P_SHAPE_CR] * math.atan(p[L.P_B0R] * alpha_r))
        fyf = shape_f * (_load_factor(fz_fl, fz_f0, eps) * _ellipse(fx_fl, fz_fl, mu)
                         + _load_factor(fz_fr, fz_f0, eps) * _ellipse(fx_fr, fz_fr, mu))
        fyr = shape_r * (_load_factor(fz_rl, fz_r0, eps) * _ellipse(fx_rl, fz_rl, mu)
                         + _load_factor(fz_rr, fz_r0, eps) * _ellipse(fx_rr, fz_rr, mu))

        fx_body = fxf * cos_d - fyf * sin_d + fxr - f_resist
        fy_body = fxf * sin_d + fyf * cos_d + fyr
        mz = (a1 * (fxf * sin_d + fyf * cos_d) - a2 * fyr
              + 0.5 * tw * ((fx_fr - fx_fl) * cos_d + (fx_rr - fx_rl)))
        dvx_dyn = fx_body / m + r * vy
        dvy_dyn = fy_body / m - r * vx
        dr_dyn = mz / iz

        v_lo = p[L.P_VBLEND_LO]
        v_hi = p[L.P_VBLEND_HI]
        if vx >= v_hi:
            dvx, dvy, dr = dvx_dyn, dvy_dyn, dr_dyn
        else:
            # Kinematic single-track model (no rear slip) pulled onto its manifold with tau_kin.
            tan_d = math.tan(delta)
            sec2 = 1.0 / (cos_d * cos_d)
            dvx_kin = (fxf * cos_d + fxr - f_resist) / m
            vy_kin = vx * a2 * tan_d / wb
            r_kin = vx * tan_d / wb
            tau_k = p[L.P_TAU_KIN]
            dvy_kin = (dvx_kin * a2 * tan_d + vx * a2 * ddelta * sec2) / wb + (vy_kin - vy) / tau_k
            dr_kin = (dvx_kin * tan_d + vx * ddelta * sec2) / wb + (r_kin - r) / tau_k
            w = _clip((vx - v_lo) / (v_hi - v_lo), 0.0, 1.0)
            w = w * w * (3.0 - 2.0 * w)
            dvx = w * dvx_dyn + (1.0 - w) * dvx_kin
            dvy = w * dvy_dyn + (1.0 - w) * dvy_kin
            dr = w * dr_dyn + (1.0 - w) * dr_kin
        ax = dvx - r * vy
        ay = dvy + r * vx
        # Roll of the sprung mass about the roll axis (ISO: positive = right side down).
        m_s = p[L.P_MS]
        h_s = p[L.P_HS]
        droll = roll_rate
        droll_rate = (m_s * h_s * (ay * math.cos(roll) + _G * math.sin(roll))
                      - p[L.P_KROLL] * roll - p[L.P_CROLL] * roll_rate) / p[L.P_IROLL]

    cos_psi = math.cos(psi)
    sin_psi = math.sin(psi)
    tau_lt = p[L.P_TAU_LT]
    dx[L.S_X] = vx * cos_psi - vy * sin_psi
    dx[L.S_Y] = vx * sin_psi + vy * cos_psi
    dx[L.S_PSI] = r
    dx[L.S_VX] = dvx
    dx[L.S_VY] = dvy
    dx[L.S_R] = dr
    dx[L.S_ROLL] = droll
    dx[L.S_ROLL_RATE] = droll_rate
    dx[L.S_DELTA] = ddelta
    dx[L.S_AXL] = (ax - ax_lag) / tau_lt
    dx[L.S_AYL] = (ay - ay_lag) / tau_lt
    dx[L.S_ALF] = dalpha_f
    dx[L.S_ALR] = dalpha_r

    out[L.O_AX] = ax
    out[L.O_AY] = ay
    out[L.O_AZ] = az_road
    out[L.O_FZFL] = fz_fl
    out[L.O_FZFR] = fz_fr
    out[L.O_FZRL] = fz_rl
    out[L.O_FZRR] = fz_rr


def state_derivative(x: np.ndarray, delta_cmd: float, throttle: float, pedal: float, p: np.ndarray,
                     model: int = L.MODEL_NONLINEAR, grade_rad: float = 0.0,
                     a_z_road_mps2: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """The plant's time derivative of one state row ``x`` (``N_STATE``) and its outputs (``N_OUTPUT``: a_x, a_y
    [m/s^2], a_z, the four F_z [N]) for inputs clipped as ``step_vehicle`` clips them (steady-state analysis)."""
    delta_max = p[L.P_DELTA_MAX]
    dx = np.zeros(L.N_STATE)
    out = np.zeros(L.N_OUTPUT)
    _derivatives(np.asarray(x, dtype=np.float64), _clip(float(delta_cmd), -delta_max, delta_max),
                 _clip(float(throttle), 0.0, 1.0), _clip(float(pedal), 0.0, p[L.P_PEDAL_MAX]),
                 math.cos(grade_rad), math.sin(grade_rad), float(a_z_road_mps2), p, model, dx, out)
    return dx, out


WORKSPACE_SIZE = 5 * L.N_STATE + L.N_OUTPUT
"""Scratch floats one vehicle needs per step (RK4 stages, stage state, throw-away outputs)."""


@njit(cache=True)
def step_vehicle(x: np.ndarray, u: np.ndarray, road: np.ndarray, p: np.ndarray, model: int, dt: float,
                 n_sub: int, outputs: np.ndarray, work: np.ndarray) -> None:
    """Advance one vehicle by ``n_sub`` RK4 steps of ``dt`` [s] in place.

    ``outputs`` (n_sub, N_OUTPUT) receives the accelerations and loads at the start of every physics step;
    ``work`` is a scratch vector of ``WORKSPACE_SIZE`` floats.
    """
    n = L.N_STATE
    k1 = work[0:n]
    k2 = work[n:2 * n]
    k3 = work[2 * n:3 * n]
    k4 = work[3 * n:4 * n]
    tmp = work[4 * n:5 * n]
    scratch = work[5 * n:5 * n + L.N_OUTPUT]
    delta_max = p[L.P_DELTA_MAX]
    cmd = _clip(u[L.U_DELTA], -delta_max, delta_max)
    throttle = _clip(u[L.U_THROTTLE], 0.0, 1.0)
    pedal = _clip(u[L.U_BRAKE], 0.0, p[L.P_PEDAL_MAX])
    cos_g = math.cos(road[L.R_GRADE])
    sin_g = math.sin(road[L.R_GRADE])
    az = road[L.R_AZ]
    if p[L.P_TAU_STEER] <= 0.0:
        x[L.S_DELTA] = cmd
    half = 0.5 * dt
    for j in range(n_sub):
        _derivatives(x, cmd, throttle, pedal, cos_g, sin_g, az, p, model, k1, outputs[j])
        for i in range(n):
            tmp[i] = x[i] + half * k1[i]
        _derivatives(tmp, cmd, throttle, pedal, cos_g, sin_g, az, p, model, k2, scratch)
        for i in range(n):
            tmp[i] = x[i] + half * k2[i]
        _derivatives(tmp, cmd, throttle, pedal, cos_g, sin_g, az, p, model, k3, scratch)
        for i in range(n):
            tmp[i] = x[i] + dt * k3[i]
        _derivatives(tmp, cmd, throttle, pedal, cos_g, sin_g, az, p, model, k4, scratch)
        for i in range(n):
            x[i] += dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])


@njit(cache=True)
def step_batch_serial(states: np.ndarray, inputs: np.ndarray, road: np.ndarray, params: np.ndarray,
                      models: np.ndarray, dt: float, n_sub: int, outputs: np.ndarray, work: np.ndarray) -> None:
    """Advance every vehicle (rows) by one control period; single-threaded (best for small N)."""
    for i in range(states.shape[0]):
        step_vehicle(states[i], inputs[i], road[i], params[i], models[i], dt, n_sub, outputs[i], work[i])


@njit(cache=True, parallel=True)
def step_batch_parallel(states: np.ndarray, inputs: np.ndarray, road: np.ndarray, params: np.ndarray,
                        models: np.ndarray, dt: float, n_sub: int, outputs: np.ndarray, work: np.ndarray) -> None:
    """Same as ``step_batch_serial`` with vehicles spread over threads (large N)."""
    for i in prange(states.shape[0]):
        step_vehicle(states[i], inputs[i], road[i], params[i], models[i], dt, n_sub, outputs[i], work[i])
