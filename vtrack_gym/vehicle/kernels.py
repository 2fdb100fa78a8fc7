"""Compiled (numba) vehicle dynamics: one implementation for N vehicles, N = 1 included.

Imported lazily (``vtrack_gym.vehicle.plant`` imports it on first use) so that ``import vtrack_gym`` stays
fast. All functions compile through ``vtrack_gym._jit.kernel`` (cached, without fastmath), so every vehicle of a
batch follows exactly the same IEEE operations as a single vehicle: batched and single runs are bit-identical.

Models (selected per vehicle by an integer id, see ``layout.MODEL_IDS``), one function each in CommonRoad's
``f(x, u, p)`` shape (``linear_model``, ``nonlinear_model``: state, clipped inputs, road, parameters -> ``dx`` and
the outputs), built from shared pieces (steering actuator, axle and wheel loads, longitudinal forces):

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

from vtrack_gym._jit import kernel, prange
from vtrack_gym.vehicle import layout as L
from vtrack_gym.vehicle.params import GRAVITY_MPS2

_G = GRAVITY_MPS2  # short name for the formulas; numba freezes it as a compile-time constant
_V_SIGN_EPS = 0.1      # [m/s] speed scale of the smooth sign used by brakes and rolling resistance
_V_DYN_MIN = 0.5       # [m/s] floor of v_x inside slip angles (the dynamic model's weight is 0 there)
_V_LIN_MIN = 1.0       # [m/s] floor of v_x in the linear model's divisions


@kernel
def _clip(v: float, lo: float, hi: float) -> float:
    return lo if v < lo else (hi if v > hi else v)


@kernel
def _load_factor(fz: float, fz0: float, eps: float) -> float:
    """Effective load of a wheel [N]: F_z (1 - eps (F_z/F_z0 - 1)), degressive, >= 0."""
    if fz <= 0.0:
        return 0.0
    g = fz * (1.0 - eps * (fz / fz0 - 1.0))
    return g if g > 0.0 else 0.0


@kernel
def _ellipse(fx: float, fz: float, mu: float) -> float:
    """Friction-ellipse derating sqrt(1 - (F_x / (mu F_z))^2) of a wheel's lateral force."""
    if fz <= 0.0:
        return 0.0
    ratio = fx / (mu * fz)
    rem = 1.0 - ratio * ratio
    return math.sqrt(rem) if rem > 0.0 else 0.0


@kernel(inline=True)
def _relaxed_slip(alpha: float, alpha_lag: float, vx: float, sigma: float) -> tuple[float, float]:
    """Slip angle [rad] the tyre force sees and d(alpha_lag)/dt [rad/s]: with a relaxation length ``sigma`` [m] > 0
    the lagged angle, which follows ``alpha`` with the time constant sigma / |v_x|; with 0 ``alpha`` itself."""
    if sigma <= 0.0:
        return alpha, 0.0
    return alpha_lag, abs(vx) / sigma * (alpha - alpha_lag)


@kernel(inline=True)
def _capped(fx: float, fz: float, mu: float) -> float:
    """A wheel's longitudinal force [N] capped at +-mu F_z (no wheel-spin degree of freedom)."""
    return _clip(fx, -mu * max(fz, 0.0), mu * max(fz, 0.0))


@kernel(inline=True)
def _steering_rate(cmd: float, delta: float, p: np.ndarray) -> float:
    """Steering actuator [rad/s]: first-order lag with rate limit (tau = 0: ideal, set by the stepper)."""
    tau_s = p[L.P_TAU_STEER]
    if tau_s > 0.0:
        rate = p[L.P_DELTA_RATE]
        return _clip((cmd - delta) / tau_s, -rate, rate)
    return 0.0


@kernel(inline=True)
def _axle_loads(ax_lag: float, cos_g: float, az_road: float, p: np.ndarray) -> tuple[float, float, float]:
    """(total, front axle, rear axle) normal load [N]: static on the grade plus longitudinal transfer of the lagged
    a_x [m/s^2]."""
    m = p[L.P_M]
    a1 = p[L.P_A1]
    a2 = p[L.P_A2]
    wb = p[L.P_L]
    h = p[L.P_HCG]
    fz_total = m * (_G * cos_g + az_road)
    fzf_axle = fz_total * a2 / wb - m * ax_lag * h / wb
    fzr_axle = fz_total * a1 / wb + m * ax_lag * h / wb
    return fz_total, fzf_axle, fzr_axle


@kernel(inline=True)
def _wheel_loads(fzf_axle: float, fzr_axle: float, d_f: float, d_r: float) -> tuple[float, float, float, float]:
    """(FL, FR, RL, RR) normal loads [N]: each axle's load shared equally, shifted by its lateral transfer [N]."""
    return 0.5 * fzf_axle - d_f, 0.5 * fzf_axle + d_f, 0.5 * fzr_axle - d_r, 0.5 * fzr_axle + d_r


@kernel(inline=True)
def _longitudinal_forces(vx: float, throttle: float, pedal: float, fz_total: float, sin_g: float,
                         p: np.ndarray) -> tuple[float, float, float]:
    """(drive/brake force per front wheel, per rear wheel, resistance) [N]: power-limited drive, brakes with a
    smooth sign at standstill; drag, rolling resistance and grade."""
    v_pos = vx if vx > 1.0 else 1.0
    f_drive = throttle * min(p[L.P_FDRIVE_MAX], p[L.P_PMAX] / v_pos)
    # tanh(x) rounds to exactly +-1.0 for |x| > 19.1, so the shortcut is bit-identical.
    sgn = math.tanh(vx / _V_SIGN_EPS) if abs(vx) < 2.0 else (1.0 if vx > 0.0 else -1.0)
    f_brake = p[L.P_BRAKE_GAIN] * pedal * sgn
    share_d = p[L.P_DRIVE_SHARE_F]
    share_b = p[L.P_BRAKE_SHARE_F]
    fx_f_each = 0.5 * (share_d * f_drive - share_b * f_brake)
    fx_r_each = 0.5 * ((1.0 - share_d) * f_drive - (1.0 - share_b) * f_brake)
    f_resist = p[L.P_DRAG_K] * vx * abs(vx) + p[L.P_FROLL] * fz_total * sgn + p[L.P_M] * _G * sin_g
    return fx_f_each, fx_r_each, f_resist


@kernel(inline=True)
def _write_rates(x: np.ndarray, dvx: float, dvy: float, dr: float, droll: float, droll_rate: float, ddelta: float,
                 ax: float, ay: float, dalpha_f: float, dalpha_r: float, p: np.ndarray, dx: np.ndarray) -> None:
    """Fill ``dx`` from the body-frame accelerations: global position rates, the load-transfer lags and the slip
    angles' relaxation rates [rad/s]."""
    psi = x[L.S_PSI]
    vx = x[L.S_VX]
    vy = x[L.S_VY]
    cos_psi = math.cos(psi)
    sin_psi = math.sin(psi)
    tau_lt = p[L.P_TAU_LT]
    dx[L.S_X] = vx * cos_psi - vy * sin_psi
    dx[L.S_Y] = vx * sin_psi + vy * cos_psi
    dx[L.S_PSI] = x[L.S_R]
    dx[L.S_VX] = dvx
    dx[L.S_VY] = dvy
    dx[L.S_R] = dr
    dx[L.S_ROLL] = droll
    dx[L.S_ROLL_RATE] = droll_rate
    dx[L.S_DELTA] = ddelta
    dx[L.S_AXL] = (ax - x[L.S_AXL]) / tau_lt
    dx[L.S_AYL] = (ay - x[L.S_AYL]) / tau_lt
    dx[L.S_ALF] = dalpha_f
    dx[L.S_ALR] = dalpha_r


@kernel(inline=True)
def _write_outputs(out: np.ndarray, ax: float, ay: float, az_road: float, fz_fl: float, fz_fr: float, fz_rl: float,
                   fz_rr: float) -> None:
    """Fill ``out``: a_x, a_y, a_z [m/s^2] and the four wheel loads [N]."""
    out[L.O_AX] = ax
    out[L.O_AY] = ay
    out[L.O_AZ] = az_road
    out[L.O_FZFL] = fz_fl
    out[L.O_FZFR] = fz_fr
    out[L.O_FZRL] = fz_rl
    out[L.O_FZRR] = fz_rr


# ------------------------------------------------------------------------------------------- linear model
@kernel(inline=True)
def linear_model(x: np.ndarray, cmd: float, throttle: float, pedal: float, cos_g: float, sin_g: float,
                 az_road: float, p: np.ndarray, dx: np.ndarray, out: np.ndarray) -> None:
    """The paper's eq. (5): ``dx`` = f(x, u, p) of state ``x`` for clipped inputs ``cmd`` [rad], ``throttle``
    [0..1], ``pedal`` [N] on a road of grade cos/sin and vertical acceleration ``az_road`` [m/s^2]; ``out``
    receives a_x, a_y, a_z and the quasi-static wheel loads."""
    m = p[L.P_M]
    a1 = p[L.P_A1]
    a2 = p[L.P_A2]
    wb = p[L.P_L]
    vx = x[L.S_VX]
    vy = x[L.S_VY]
    r = x[L.S_R]
    delta = x[L.S_DELTA]
    ay_lag = x[L.S_AYL]
    ddelta = _steering_rate(cmd, delta, p)
    fz_total, fzf_axle, fzr_axle = _axle_loads(x[L.S_AXL], cos_g, az_road, p)
    d_f = m * ay_lag * p[L.P_HCG] * (a2 / wb) / p[L.P_TRACK]
    d_r = m * ay_lag * p[L.P_HCG] * (a1 / wb) / p[L.P_TRACK]
    fz_fl, fz_fr, fz_rl, fz_rr = _wheel_loads(fzf_axle, fzr_axle, d_f, d_r)
    fx_f_each, fx_r_each, f_resist = _longitudinal_forces(vx, throttle, pedal, fz_total, sin_g, p)
    cos_d = math.cos(delta)
    sin_d = math.sin(delta)
    vxs = vx if vx > _V_LIN_MIN else _V_LIN_MIN
    fyf = p[L.P_CF] * (delta - (vy + a1 * r) / vxs)
    fyr = -p[L.P_CR] * (vy - a2 * r) / vxs
    fxf = 2.0 * fx_f_each
    fxr = 2.0 * fx_r_each
    dvx = (fxf * cos_d - fyf * sin_d + fxr - f_resist) / m + r * vy
    dvy = (fyf + fyr) / m - r * vxs
    dr = (a1 * fyf - a2 * fyr) / p[L.P_IZ]
    ax = dvx - r * vy
    ay = dvy + r * vxs
    _write_rates(x, dvx, dvy, dr, 0.0, 0.0, ddelta, ax, ay, 0.0, 0.0, p, dx)
    _write_outputs(out, ax, ay, az_road, fz_fl, fz_fr, fz_rl, fz_rr)


# ---------------------------------------------------------------------------------------- nonlinear model
@kernel(inline=True)
def _roll_transfer(x: np.ndarray, p: np.ndarray) -> tuple[float, float]:
    """Lateral load transfer [N] of the front and the rear axle: the roll spring/damper moment (front share) plus
    the roll-centre and unsprung parts of the lagged a_y."""
    m_roll = p[L.P_KROLL] * x[L.S_ROLL] + p[L.P_CROLL] * x[L.S_ROLL_RATE]
    share = p[L.P_ROLL_SHARE_F]
    ay_lag = x[L.S_AYL]
    tw = p[L.P_TRACK]
    d_f = (share * m_roll + ay_lag * p[L.P_LT_DIRECT_F]) / tw
    d_r = ((1.0 - share) * m_roll + ay_lag * p[L.P_LT_DIRECT_R]) / tw
    return d_f, d_r


@kernel(inline=True)
def _lateral_tyre_forces(x: np.ndarray, p: np.ndarray, fz_fl: float, fz_fr: float, fz_rl: float, fz_rr: float,
                         fx_fl: float, fx_fr: float, fx_rl: float,
                         fx_rr: float) -> tuple[float, float, float, float]:
    """(front, rear) axle lateral force [N]: the Pacejka shape once per axle (at the relaxed slip angles), scaled
    per wheel by its effective load and friction ellipse; then the slip angles' relaxation rates [rad/s]."""
    m = p[L.P_M]
    a1 = p[L.P_A1]
    a2 = p[L.P_A2]
    wb = p[L.P_L]
    mu = p[L.P_MU]
    r = x[L.S_R]
    vy = x[L.S_VY]
    vxs = x[L.S_VX] if x[L.S_VX] > _V_DYN_MIN else _V_DYN_MIN
    alpha_f = x[L.S_DELTA] - math.atan2(vy + a1 * r, vxs)
    alpha_r = -math.atan2(vy - a2 * r, vxs)
    alpha_f, dalpha_f = _relaxed_slip(alpha_f, x[L.S_ALF], vxs, p[L.P_RELAX])
    alpha_r, dalpha_r = _relaxed_slip(alpha_r, x[L.S_ALR], vxs, p[L.P_RELAX])
    fz_f0 = 0.5 * m * _G * a2 / wb  # static load of one wheel on flat ground (B0's reference)
    fz_r0 = 0.5 * m * _G * a1 / wb
    eps = p[L.P_LOAD_SENS]
    shape_f = mu * p[L.P_PEAK_DF] * math.sin(p[L.P_SHAPE_CF] * math.atan(p[L.P_B0F] * alpha_f))
    shape_r = mu * p[L.P_PEAK_DR] * math.sin(p[L.P_SHAPE_CR] * math.atan(p[L.P_B0R] * alpha_r))
    fyf = shape_f * (_load_factor(fz_fl, fz_f0, eps) * _ellipse(fx_fl, fz_fl, mu)
                     + _load_factor(fz_fr, fz_f0, eps) * _ellipse(fx_fr, fz_fr, mu))
    fyr = shape_r * (_load_factor(fz_rl, fz_r0, eps) * _ellipse(fx_rl, fz_rl, mu)
                     + _load_factor(fz_rr, fz_r0, eps) * _ellipse(fx_rr, fz_rr, mu))
    return fyf, fyr, dalpha_f, dalpha_r


@kernel(inline=True)
def _kinematic_rates(x: np.ndarray, p: np.ndarray, fxf: float, fxr: float, f_resist: float, ddelta: float,
                     cos_d: float) -> tuple[float, float, float]:
    """(v_x', v_y', r') of the kinematic single-track model (no rear slip), pulled onto its manifold with
    tau_kin."""
    m = p[L.P_M]
    a2 = p[L.P_A2]
    wb = p[L.P_L]
    vx = x[L.S_VX]
    tan_d = math.tan(x[L.S_DELTA])
    sec2 = 1.0 / (cos_d * cos_d)
    dvx_kin = (fxf * cos_d + fxr - f_resist) / m
    vy_kin = vx * a2 * tan_d / wb
    r_kin = vx * tan_d / wb
    tau_k = p[L.P_TAU_KIN]
    dvy_kin = (dvx_kin * a2 * tan_d + vx * a2 * ddelta * sec2) / wb + (vy_kin - x[L.S_VY]) / tau_k
    dr_kin = (dvx_kin * tan_d + vx * ddelta * sec2) / wb + (r_kin - x[L.S_R]) / tau_k
    return dvx_kin, dvy_kin, dr_kin


@kernel(inline=True)
def _roll_acceleration(x: np.ndarray, ay: float, p: np.ndarray) -> float:
    """Roll acceleration [rad/s^2] of the sprung mass about the roll axis (ISO: positive = right side down)."""
    roll = x[L.S_ROLL]
    return (p[L.P_MS] * p[L.P_HS] * (ay * math.cos(roll) + _G * math.sin(roll))
            - p[L.P_KROLL] * roll - p[L.P_CROLL] * x[L.S_ROLL_RATE]) / p[L.P_IROLL]


@kernel(inline=True)
def nonlinear_model(x: np.ndarray, cmd: float, throttle: float, pedal: float, cos_g: float, sin_g: float,
                    az_road: float, p: np.ndarray, dx: np.ndarray, out: np.ndarray) -> None:
    """The default plant (module docstring): ``dx`` = f(x, u, p), arguments as ``linear_model``'s; ``out``
    receives a_x, a_y, a_z and the four wheel loads. Blends to the kinematic model below ``v_blend_hi``."""
    m = p[L.P_M]
    a1 = p[L.P_A1]
    a2 = p[L.P_A2]
    tw = p[L.P_TRACK]
    mu = p[L.P_MU]
    vx = x[L.S_VX]
    vy = x[L.S_VY]
    r = x[L.S_R]
    ddelta = _steering_rate(cmd, x[L.S_DELTA], p)
    fz_total, fzf_axle, fzr_axle = _axle_loads(x[L.S_AXL], cos_g, az_road, p)
    d_f, d_r = _roll_transfer(x, p)
    fz_fl, fz_fr, fz_rl, fz_rr = _wheel_loads(fzf_axle, fzr_axle, d_f, d_r)
    fx_f_each, fx_r_each, f_resist = _longitudinal_forces(vx, throttle, pedal, fz_total, sin_g, p)
    fx_fl = _capped(fx_f_each, fz_fl, mu)
    fx_fr = _capped(fx_f_each, fz_fr, mu)
    fx_rl = _capped(fx_r_each, fz_rl, mu)
    fx_rr = _capped(fx_r_each, fz_rr, mu)
    fxf = fx_fl + fx_fr
    fxr = fx_rl + fx_rr
    fyf, fyr, dalpha_f, dalpha_r = _lateral_tyre_forces(x, p, fz_fl, fz_fr, fz_rl, fz_rr, fx_fl, fx_fr, fx_rl, fx_rr)
    cos_d = math.cos(x[L.S_DELTA])
    sin_d = math.sin(x[L.S_DELTA])
    fx_body = fxf * cos_d - fyf * sin_d + fxr - f_resist
    fy_body = fxf * sin_d + fyf * cos_d + fyr
    mz = (a1 * (fxf * sin_d + fyf * cos_d) - a2 * fyr
          + 0.5 * tw * ((fx_fr - fx_fl) * cos_d + (fx_rr - fx_rl)))
    dvx = fx_body / m + r * vy
    dvy = fy_body / m - r * vx
    dr = mz / p[L.P_IZ]
    v_lo = p[L.P_VBLEND_LO]
    v_hi = p[L.P_VBLEND_HI]
    if not vx >= v_hi:  # the blend (NaN speeds included, as the blend propagates them)
        dvx_kin, dvy_kin, dr_kin = _kinematic_rates(x, p, fxf, fxr, f_resist, ddelta, cos_d)
        w = _clip((vx - v_lo) / (v_hi - v_lo), 0.0, 1.0)
        w = w * w * (3.0 - 2.0 * w)
        dvx = w * dvx + (1.0 - w) * dvx_kin
        dvy = w * dvy + (1.0 - w) * dvy_kin
        dr = w * dr + (1.0 - w) * dr_kin
    ax = dvx - r * vy
    ay = dvy + r * vx
    _write_rates(x, dvx, dvy, dr, x[L.S_ROLL_RATE], _roll_acceleration(x, ay, p), ddelta, ax, ay, dalpha_f,
                 dalpha_r, p, dx)
    _write_outputs(out, ax, ay, az_road, fz_fl, fz_fr, fz_rl, fz_rr)


@kernel
def _derivatives(x: np.ndarray, cmd: float, throttle: float, pedal: float, cos_g: float, sin_g: float,
                 az_road: float, p: np.ndarray, model: int, dx: np.ndarray, out: np.ndarray) -> None:
    """Time derivative ``dx`` of state ``x`` under vehicle model ``model`` (``layout.MODEL_IDS``), inputs already
    clipped to their ranges: ``cmd`` road-wheel command [rad], ``throttle`` [0..1], ``pedal`` brake pedal force
    [N], road grade as cos/sin, ``az_road`` [m/s^2]. ``out`` receives a_x, a_y, a_z [m/s^2] and the four F_z [N]."""
    if model == L.MODEL_LINEAR:
        linear_model(x, cmd, throttle, pedal, cos_g, sin_g, az_road, p, dx, out)
    else:
        nonlinear_model(x, cmd, throttle, pedal, cos_g, sin_g, az_road, p, dx, out)


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


@kernel
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


@kernel
def step_batch_serial(states: np.ndarray, inputs: np.ndarray, road: np.ndarray, params: np.ndarray,
                      models: np.ndarray, dt: float, n_sub: int, outputs: np.ndarray, work: np.ndarray) -> None:
    """Advance every vehicle (rows) by one control period; single-threaded (best for small N)."""
    for i in range(states.shape[0]):
        step_vehicle(states[i], inputs[i], road[i], params[i], models[i], dt, n_sub, outputs[i], work[i])


@kernel(parallel=True)
def step_batch_parallel(states: np.ndarray, inputs: np.ndarray, road: np.ndarray, params: np.ndarray,
                        models: np.ndarray, dt: float, n_sub: int, outputs: np.ndarray, work: np.ndarray) -> None:
    """Same as ``step_batch_serial`` with vehicles spread over threads (large N)."""
    for i in prange(states.shape[0]):
        step_vehicle(states[i], inputs[i], road[i], params[i], models[i], dt, n_sub, outputs[i], work[i])
