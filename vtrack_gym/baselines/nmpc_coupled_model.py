"""Compiled prediction model of the coupled NMPC: the steering NMPC's lateral model plus the speed and the time
error, with two inputs (steering command, longitudinal demand), and its exact Jacobians.

State ``x = (e_y [m], e_phi [rad], v_y [m/s], r [rad/s], delta [rad], v [m/s], e_t [s])``, inputs the road-wheel
command ``c`` [rad] and the longitudinal demand ``d`` in [-1, 1], stage parameters the path curvature ``kappa``
[1/m] and the reference speed ``v_ref`` [m/s] at the stage's predicted station::

    rows e_y .. delta:  nmpc_kernels.derivative_and_jacobian at the speed max(v, v_lat_min) (Frenet single-track,
                        Pacejka axle tyres, first-order steering actuator), each axle's lateral force F_y,i
                        derated by the friction ellipse e_i = sqrt(1 - (F_x,i / (mu F_z,i))^2) (static axle
                        loads; floored at ``ELLIPSE_FLOOR``), as the plant derates each wheel's
    F_d   = max(d, 0) min(F_max, P_max / max(v, 1 m/s))               (throttle fraction; the plant's drive curve)
    F_b   = min(max(-d, 0) F_pedal,max pedal_gain, mu m g) tanh(v / 0.1 m/s)
                                                                       (brakes, at most the tyres' grip; smooth sign)
    F_xf  = s_d F_d - s_b F_b,   F_xr = (1 - s_d) F_d - (1 - s_b) F_b  (drive and brake shares front/rear)
    R(v)  = 1/2 rho C_d A v |v| + f_r m g tanh(v / 0.1 m/s)             (drag, rolling resistance)
    v'    = (F_xf cos delta - e_f F_yf sin delta + F_xr - R(v)) / m + r v_y
    e_t'  = 1 - s' / max(v_ref, v_ref_min),   s' = (v cos e_phi - v_y sin e_phi) / (1 - kappa e_y)

``e_t`` is the time error of the observation (t - T(s), positive = behind the reference's time law T, dT/ds =
1 / v_ref). The throttle/brake map is the env's (``envs.control.pedals``), the forces the plant's
(``vehicle.kernels``, flat road, no wheel slip). The plant caps every wheel's force at mu F_z with the loads
shifted by the deceleration; the model caps the total brake force at mu m g (what an ideal split of the shifted
loads allows), so a demand past about -0.42 brakes no harder, as in the plant; the drive force is not capped.
Jacobian columns: d/dx (7), d/dc, d/dd, d/dkappa, d/dv_ref (``N_SENS`` = 11); at d = 0 the throttle side's slope
is taken.

Longitudinal constants ``lc`` (``longitudinal_constants``): m [kg], F_max [N], P_max [W], drag coefficient
1/2 rho C_d A [kg/m], rolling force f_r m g [N], full brake force F_pedal,max pedal_gain [N], drive share s_d,
brake share s_b, lateral-model speed floor [m/s], reference-speed floor [m/s], grip force mu m g [N] and per axle
mu F_z,f, mu F_z,r [N] (static loads).
"""

from __future__ import annotations

import math

import numpy as np

from vtrack_gym._jit import kernel
from vtrack_gym.baselines.nmpc_kernels import derivative_and_jacobian
from vtrack_gym.baselines.rti_kernels import rk4_sensitivities

N_X = 7
"""e_y, e_phi, v_y, r, delta, v, e_t."""
N_SENS = 11
"""Sensitivity columns of a stage: d/dx_start (7), d/dc, d/dd, d/dkappa, d/dv_ref."""
SIGN_SPEED_MPS = 0.1
"""Speed scale [m/s] of the smooth sign of brakes and rolling resistance (the plant's)."""
ELLIPSE_FLOOR = 0.1
"""Least friction-ellipse factor of an axle's lateral force (keeps the factor's slope finite at the grip)."""


def longitudinal_constants(vehicle: object, v_lat_min_mps: float, v_ref_min_mps: float) -> np.ndarray:
    """``lc`` of the module docstring from a ``VehicleParams`` (its tyres' friction coefficient) and the two speed
    floors [m/s]."""
    from vtrack_gym.vehicle.params import GRAVITY_MPS2

    p, b, c, m = vehicle.powertrain, vehicle.brakes, vehicle.chassis, vehicle.chassis.mass_kg
    mu, wheelbase = vehicle.tyres.friction_mu, c.cg_to_front_axle_m + c.cg_to_rear_axle_m
    return np.array([m, p.max_drive_force_n, p.max_power_w, 0.5 * p.air_density_kgpm3 * p.drag_area_m2,
                     vehicle.tyres.rolling_resistance_coeff * m * GRAVITY_MPS2, b.pedal_gain * b.max_pedal_force_n,
                     p.front_drive_share, b.front_brake_share, v_lat_min_mps, v_ref_min_mps,
                     mu * m * GRAVITY_MPS2, mu * m * GRAVITY_MPS2 * c.cg_to_rear_axle_m / wheelbase,
                     mu * m * GRAVITY_MPS2 * c.cg_to_front_axle_m / wheelbase])


@kernel(inline=True)
def _front_force(x: np.ndarray, v_lat: float, mc: np.ndarray) -> tuple[float, float, float, float, float]:
    """Front axle lateral force F_yf [N] and its partials d/d(v_y, r, delta, v_lat) (the lateral model's tyre)."""
    a1 = mc[2]
    qf = (x[2] + a1 * x[3]) / v_lat
    df = 1.0 / (1.0 + qf * qf)
    zf = mc[6] * (x[4] - math.atan(qf))
    af = mc[5] * math.atan(zf)
    slope = mc[4] * math.cos(af) * mc[5] * mc[6] / (1.0 + zf * zf)
    return mc[4] * math.sin(af), -slope * df / v_lat, -slope * a1 * df / v_lat, slope, slope * qf * df / v_lat


@kernel(inline=True)
def _drive_cap(v: float, lc: np.ndarray) -> tuple[float, float]:
    """min(F_max, P_max / max(v, 1)) [N] and its derivative in v [N s/m]."""
    vp = v if v > 1.0 else 1.0
    if lc[1] <= lc[2] / vp:
        return lc[1], 0.0
    return lc[2] / vp, (-lc[2] / (vp * vp) if v > 1.0 else 0.0)


@kernel(inline=True)
def _rear_force(x: np.ndarray, v_lat: float, mc: np.ndarray) -> tuple[float, float, float, float]:
    """Rear axle lateral force F_yr [N] and its partials d/d(v_y, r, v_lat) (the lateral model's tyre)."""
    a2 = mc[3]
    qr = (x[2] - a2 * x[3]) / v_lat
    dr = 1.0 / (1.0 + qr * qr)
    zr = -mc[9] * math.atan(qr)
    ar = mc[8] * math.atan(zr)
    slope = mc[7] * math.cos(ar) * mc[8] * mc[9] / (1.0 + zr * zr)
    return mc[7] * math.sin(ar), -slope * dr / v_lat, slope * a2 * dr / v_lat, slope * qr * dr / v_lat


@kernel(inline=True)
def _ellipse(fx: float, grip: float) -> tuple[float, float]:
    """Friction-ellipse factor sqrt(1 - (F_x / grip)^2) of an axle's lateral force (floored at
    ``ELLIPSE_FLOOR``) and its derivative in F_x [1/N]."""
    ratio = fx / grip
    rem = 1.0 - ratio * ratio
    if rem <= ELLIPSE_FLOOR * ELLIPSE_FLOOR:
        return ELLIPSE_FLOOR, 0.0
    e = math.sqrt(rem)
    return e, -ratio / (grip * e)


@kernel(inline=True)
def _axle_forces(v: float, c_d: float, lc: np.ndarray) -> tuple[float, float, float, float, float, float, float,
                                                                  float]:
    """(F_xf, F_xr [N], their partials in d and in v, R(v) [N] and dR/dv) of the module docstring."""
    s_d, s_b = lc[6], lc[7]
    cap, dcap = _drive_cap(v, lc)
    sgn = math.tanh(v / SIGN_SPEED_MPS)
    dsgn = (1.0 - sgn * sgn) / SIGN_SPEED_MPS
    thr, brk = (c_d, 0.0) if c_d >= 0.0 else (0.0, -c_d)
    gripped = lc[5] * brk > lc[10]   # the brake force past the grip: no harder
    braking = lc[10] if gripped else lc[5] * brk
    f_drive, f_brake = thr * cap, braking * sgn
    if c_d >= 0.0:   # d F_drive / d d = cap, d F_brake / d d = 0
        xf_dd, xr_dd = s_d * cap, (1.0 - s_d) * cap
    else:            # d F_brake / d d = -full brake x sgn (0 past the grip)
        slope = 0.0 if gripped else lc[5] * sgn
        xf_dd, xr_dd = s_b * slope, (1.0 - s_b) * slope
    dfd_dv, dfb_dv = thr * dcap, braking * dsgn
    return (s_d * f_drive - s_b * f_brake, (1.0 - s_d) * f_drive - (1.0 - s_b) * f_brake, xf_dd, xr_dd,
            s_d * dfd_dv - s_b * dfb_dv, (1.0 - s_d) * dfd_dv - (1.0 - s_b) * dfb_dv,
            lc[3] * v * abs(v) + lc[4] * sgn, 2.0 * lc[3] * abs(v) + lc[4] * dsgn)


@kernel(inline=True)
def _add_derating(jac: np.ndarray, col: int, dgf: float, dgr: float, mc: np.ndarray) -> None:
    """Add the derating terms' partials (front dgf, rear dgr [N per unit]) to the v_y and r rows' column ``col``."""
    jac[2, col] += (dgf + dgr) / mc[0]
    jac[3, col] += (mc[2] * dgf - mc[3] * dgr) / mc[1]


@kernel(inline=True)
def _grip_rows(x: np.ndarray, c_d: float, v_lat: float, lat: bool, mc: np.ndarray, lc: np.ndarray, f: np.ndarray,
               jac: np.ndarray) -> None:
    """The longitudinal forces' share of the tyres' grip: derate the lateral rows' axle forces by the friction
    ellipse (rows v_y and r) and write the speed row v' (row 5), with their partials."""
    v_y, r, delta = x[2], x[3], x[4]
    fxf, fxr, xf_dd, xr_dd, xf_dv, xr_dv, resist, dres_dv = _axle_forces(x[5], c_d, lc)
    ef, def_dx = _ellipse(fxf, lc[11])
    er, der_dx = _ellipse(fxr, lc[12])
    fyf, ff_vy, ff_r, ff_delta, ff_v = _front_force(x, v_lat, mc)
    fyr, fr_vy, fr_r, fr_v = _rear_force(x, v_lat, mc)
    if not lat:
        ff_v, fr_v = 0.0, 0.0
    cd, sd = math.cos(delta), math.sin(delta)
    gf, gr = (ef - 1.0) * fyf * cd, (er - 1.0) * fyr    # the lateral rows' forces become ef F_yf, er F_yr
    f[2] += (gf + gr) / mc[0]
    f[3] += (mc[2] * gf - mc[3] * gr) / mc[1]
    _add_derating(jac, 2, (ef - 1.0) * cd * ff_vy, (er - 1.0) * fr_vy, mc)
    _add_derating(jac, 3, (ef - 1.0) * cd * ff_r, (er - 1.0) * fr_r, mc)
    _add_derating(jac, 4, (ef - 1.0) * (ff_delta * cd - fyf * sd), 0.0, mc)
    _add_derating(jac, 5, (ef - 1.0) * cd * ff_v + fyf * cd * def_dx * xf_dv, (er - 1.0) * fr_v
                  + fyr * der_dx * xr_dv, mc)
    _add_derating(jac, 8, fyf * cd * def_dx * xf_dd, fyr * der_dx * xr_dd, mc)
    m = mc[0]
    jac[5, 2] = -ef * ff_vy * sd / m + r
    jac[5, 3] = -ef * ff_r * sd / m + v_y
    jac[5, 4] = (-fxf * sd - ef * (ff_delta * sd + fyf * cd)) / m
    jac[5, 5] = (xf_dv * cd - sd * (ef * ff_v + fyf * def_dx * xf_dv) + xr_dv - dres_dv) / lc[0]
    jac[5, 8] = (xf_dd * cd - sd * fyf * def_dx * xf_dd + xr_dd) / lc[0]
    f[5] = (fxf * cd - ef * fyf * sd + fxr - resist) / lc[0] + r * v_y


@kernel(inline=True)
def _time_row(x: np.ndarray, kappa: float, v_ref: float, lc: np.ndarray, jac: np.ndarray) -> float:
    """e_t' [s/s] (module docstring) and its partials into row 6 of ``jac``."""
    e_y, e_phi, v_y, v = x[0], x[1], x[2], x[5]
    floored = v_ref <= lc[9]
    vr = lc[9] if floored else v_ref
    cp, sp = math.cos(e_phi), math.sin(e_phi)
    den = 1.0 - kappa * e_y
    num = v * cp - v_y * sp
    s_dot = num / den
    jac[6, 0] = -(num * kappa / (den * den)) / vr
    jac[6, 1] = -((-v * sp - v_y * cp) / den) / vr
    jac[6, 2] = (sp / den) / vr
    jac[6, 5] = -(cp / den) / vr
    jac[6, 9] = -(num * e_y / (den * den)) / vr
    jac[6, 10] = 0.0 if floored else s_dot / (vr * vr)
    return 1.0 - s_dot / vr


@kernel(inline=True)
def coupled_derivative(x: np.ndarray, c: float, c_d: float, kappa: float, v_ref: float, mc: np.ndarray,
                       lc: np.ndarray, f: np.ndarray, jac: np.ndarray, f5: np.ndarray, jac5: np.ndarray) -> None:
    """x' into ``f`` (7,) and d x' / d(x, c, d, kappa, v_ref) into ``jac`` (7, 11); ``f5`` (5,), ``jac5`` (5, 8)
    are work arrays of the lateral model."""
    lat = x[5] > lc[8]
    v_lat = x[5] if lat else lc[8]
    derivative_and_jacobian(x[:5], c, v_lat, kappa, mc, f5, jac5)
    jac[:, :] = 0.0
    for i in range(5):
        f[i] = f5[i]
        for j in range(5):
            jac[i, j] = jac5[i, j]
        jac[i, 5] = jac5[i, 6] if lat else 0.0
        jac[i, 7] = jac5[i, 5]
        jac[i, 9] = jac5[i, 7]
    _grip_rows(x, c_d, v_lat, lat, mc, lc, f, jac)
    f[6] = _time_row(x, kappa, v_ref, lc, jac)


@kernel
def derivative(x: np.ndarray, c: float, c_d: float, kappa: float, v_ref: float, mc: np.ndarray,
               lc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """x' (7,) and its Jacobian (7, 11) at one point (what the tests compare with finite differences)."""
    f, jac = np.empty(N_X), np.empty((N_X, N_SENS))
    coupled_derivative(x, c, c_d, kappa, v_ref, mc, lc, f, jac, np.empty(5), np.empty((5, 8)))
    return f, jac


@kernel(inline=True)
def _rates(y: np.ndarray, u: np.ndarray, p: np.ndarray, consts: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
           f: np.ndarray, jac: np.ndarray) -> None:
    """``coupled_derivative`` in ``rti_kernels.rk4_sensitivities``' form (consts = (mc, lc, f5, jac5))."""
    coupled_derivative(y, u[0], u[1], p[0], p[1], consts[0], consts[1], f, jac, consts[2], consts[3])


@kernel(inline=True)
def _jac_times(jac: np.ndarray, dy: np.ndarray, out: np.ndarray) -> None:
    """``out = jac[:, :7] @ dy + [0 | jac[:, 7:]]`` (7, 11), the input and parameter columns first."""
    for i in range(N_X):
        for j in range(N_SENS):
            acc = jac[i, j] if j >= N_X else 0.0
            for q in range(N_X):
                acc += jac[i, q] * dy[q, j]
            out[i, j] = acc


@kernel
def rk4_stage(x: np.ndarray, u: np.ndarray, p: np.ndarray, mc: np.ndarray, lc: np.ndarray, stage_s: float,
              substeps: int, x_out: np.ndarray, sens: np.ndarray) -> None:
    """The state after one stage of ``stage_s`` [s] (inputs ``u`` = (c, d) and parameters ``p`` = (kappa, v_ref)
    held) into ``x_out`` (7,) and its exact sensitivities d/d(x_start, c, d, kappa, v_ref) into ``sens`` (7, 11)."""
    rk4_sensitivities(_rates, _jac_times, x, u, p, (mc, lc, np.empty(5), np.empty((5, 8))), stage_s, substeps,
                      x_out, sens, np.empty((4, N_X)), np.empty((N_X, N_SENS)), np.empty((4, N_X, N_SENS)),
                      np.empty(N_X), np.empty((N_X, N_SENS)))


@kernel
def advance(x: np.ndarray, u: np.ndarray, p: np.ndarray, mc: np.ndarray, lc: np.ndarray, duration_s: float,
            substeps: int) -> np.ndarray:
    """The state after ``duration_s`` [s] with inputs and parameters held (RK4, ``substeps`` steps)."""
    out = np.empty(N_X)
    rk4_stage(x, u, p, mc, lc, duration_s, substeps, out, np.empty((N_X, N_SENS)))
    return out
