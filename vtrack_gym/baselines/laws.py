"""The SMC and MPC control laws, written once: compiled per-row laws used by the policies and the GA kernels.

Each law takes its parameters as one ``NamedTuple`` (``SMCLaw``, ``MPCLaw``, built by ``smc_law`` /
``mpc_law``) and works on row ``i`` of an observation array (N, obs_dim). A parameter array of R rows serves
either one controller (R = 1: every observation row uses it) or a population (R = N: row i uses its own
parameters, as in the GA). ``smc_rows`` / ``mpc_rows`` loop the per-row law over a batch; ``SMC.predict`` and
``MPC.predict`` call them with N = 1 for a single observation, and ``vtrack_gym.tuning`` calls the per-row laws
inside its compiled population rollout. The arithmetic is plain IEEE float64 (no fast-math), so all paths give
the same bits for the same inputs.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np

from vtrack_gym._jit import kernel
from vtrack_gym.envs.observation import ObservationLayout
from vtrack_gym.vehicle.params import DesignModel

SMC_SIGNALS = ("v_x", "e_y", "e_phi", "e_y_dot", "e_phi_dot", "v_y", "yaw_rate", "yaw_rate_ref", "yaw_acc_ref")
"""Observation entries the SMC law reads (order of ``SMCLaw.idx``)."""
MPC_SIGNALS = ("v_x", "v_y", "yaw_rate", "e_y", "e_y_dot", "e_phi", "e_phi_dot", "yaw_acc_ref", "road_wheel_angle",
               "curvature", "curvature_rate")
"""Observation entries the MPC law reads (order of ``MPCLaw.idx``)."""
MPC_STATE_SIZE = 9
"""MPC memory per row: v_y, r, e_y, e_y_dot, e_phi, e_phi_dot at the last sample, u(k-1), d(k-1), hold count."""
TWO_PI = 2.0 * math.pi


# ------------------------------------------------------------------------------- rate-limit anticipation
ANTICIPATION_RATE_FACTOR = 2.0
"""The anticipation plans the steady-state steer just in time at this multiple of the actuator's rate limit: the
actuator, following that plan at its own rate, then ramps through every curvature change centred on it."""


MPC_ANTICIPATION_RATE_FACTOR = 3.0
"""The MPC's anticipation rate as a multiple of the actuator's rate limit (measured on benchmarks/own_tracks.py's
circuits at 0.5, 1 and 2 m point spacing: 2 leaves 1.4 m max|e_y| on the kart track, 4 fails it at 0.5 m)."""


@kernel
def rate_anticipation(obs: np.ndarray, i: int, kappa_idx: int, pv0: int, n_preview: int, pv_vmin: float,
                      pv_dt: float, v: float, steer_gain: float, rate: float, lag_s: float) -> float:
    """Anticipation [rad] to add to a steering law's command on observation row ``i`` (0.0 exactly when the
    previewed steady-state steer is reachable in time).

    The steady-state steer along the preview is ``delta_k = steer_gain kappa_k`` (``steer_gain`` = l + K_us v^2
    [m]; kappa_0 the curvature at the car, kappa_k the preview samples, reached after ``t_k = d_k / v`` [s]). A
    command delta now can still reach every delta_k if ``|delta - delta_k| <= rate max(t_k - lag_s, 0)`` (``rate``
    [rad/s], ``lag_s`` the actuator's lag [s]). If delta_0 satisfies every such bound the result is 0.0; otherwise
    it is the shift onto the nearest bound (the middle of the two bounds when they cross). Nothing below 0.5 m/s.
    """
    if v < 0.5 or rate <= 0.0:
        return 0.0
    d0 = steer_gain * float(obs[i, kappa_idx])
    lo, hi = -math.inf, math.inf
    step = pv_dt * max(v, pv_vmin) / v
    for k in range(n_preview):
        reach = rate * max((k + 1) * step - lag_s, 0.0)
        dk = steer_gain * float(obs[i, pv0 + k])
        lo = max(lo, dk - reach)
        hi = min(hi, dk + reach)
    if lo > hi:
        return 0.5 * (lo + hi) - d0
    return lo - d0 if d0 < lo else (hi - d0 if d0 > hi else 0.0)


# ------------------------------------------------------------------------------------------------------ SMC
def smc_design_constants(design: DesignModel) -> tuple[float, ...]:
    """(m a1, a2 C_ar l, C_ar l, lambda, I_z, a1^2 C_af + a2^2 C_ar, h, I_z/(a1 C_af)) of paper-math 5."""
    m, iz, a1, a2 = design.mass_kg, design.yaw_inertia_kgm2, design.cg_to_front_axle_m, design.cg_to_rear_axle_m
    cf, cr, l = design.front_cornering_stiffness_npr, design.rear_cornering_stiffness_npr, design.wheelbase_m
    return (m * a1, a2 * cr * l, cr * l, iz / (m * a1), iz, a1 * a1 * cf + a2 * a2 * cr, a1 * cf - a2 * cr,
            iz / (a1 * cf))


def smc_singular_speed(design: DesignModel) -> float:
    """v* = sqrt(C_ar l (m a1 a2 - I_z)) / (m a1) [m/s] (10.807 for the paper's car); NaN if m a1 a2 <= I_z."""
    m, iz, a1, a2 = design.mass_kg, design.yaw_inertia_kgm2, design.cg_to_front_axle_m, design.cg_to_rear_axle_m
    arg = design.rear_cornering_stiffness_npr * design.wheelbase_m * (m * a1 * a2 - iz)
    return math.sqrt(arg) / (m * a1) if arg > 0.0 else math.nan


def smc_dynamics_floor(design: DesignModel, control_period_s: float, actuator_lag_s: float,
                       guard_band_mps: float) -> float:
    """Low-speed floor [m/s] of the speed the SMC's yaw dynamics are evaluated at: the speed at which the yaw
    mode the law cancels, |K_r| = (a1^2 C_af + a2^2 C_ar)/(I_z v), is as fast as the loop's delay allows,
    1/(T_c/2 + tau) (half a control period of hold plus the actuator lag; 8.74 m/s for the paper's car). It never
    reaches the singular speed's guard band (``v* - guard_band_mps``): the coefficients change sign across v*,
    so the floor must stay on the slow side (the SUV's v* = 4.6 m/s caps its floor at 4.3 m/s)."""
    k = smc_design_constants(design)
    floor = k[5] / k[4] * (0.5 * control_period_s + actuator_lag_s)
    v_star = smc_singular_speed(design)
    return min(floor, v_star - guard_band_mps) if math.isfinite(v_star) else floor


def guarded_speed(v: float, v_star: float, band: float = 0.3) -> float:
    """``v`` [m/s], or ``v* -+ band`` on the side of ``v`` if ``|v - v*| < band`` (paper-math 5.7 guard;
    a NaN ``v*`` never guards)."""
    if band > 0.0 and abs(v - v_star) < band:
        return v_star - band if v < v_star else v_star + band
    return v


def smc_coefficient_values(k: Any, v: float, p: float) -> tuple[float, ...]:
    """(lam, f3, f4, G, c1, c2, c3, f5, f6) of (25), (29), (39) at speed ``v`` [m/s] for pole ``p`` [rad/s]."""
    ma1, a2crl, crl, lam, iz, yaw_c, h = k[0], k[1], k[2], k[3], k[4], k[5], k[6]
    f3 = (a2crl - ma1 * v * v) / (ma1 * v)
    f4 = -crl / (ma1 * v)
    g = v + f3 + lam * f4
    c1 = p * p * p / (v * f4)
    c2 = (3.0 * p * p + c1 * g + 3.0 * p * f4 + f4 * f4) / (f4 * (v - g))
    c3 = -3.0 * p - f4 - c2 * g
    f5 = -yaw_c / (iz * v) - c2 * f3
    f6 = -h / (iz * v) - c2 * f4
    return lam, f3, f4, g, c1, c2, c3, f5, f6


class SMCLaw(NamedTuple):
    """Parameters of the SMC law (31) for R parameter rows (R = 1: one controller)."""

    idx: np.ndarray        # int64 (9,): observation indices of SMC_SIGNALS
    k: np.ndarray          # (8,): smc_design_constants
    pole: np.ndarray       # (R,): p [rad/s]
    eta_k: np.ndarray      # (R,): eta I_z/(a1 C_af) [rad]
    inv_layer: np.ndarray  # (R,): 1/Delta_eff [s/rad]
    min_speed: float       # speed clamp [m/s]
    v_star: float          # singular speed [m/s] (NaN: none)
    guard: float           # guard half-band [m/s]
    shift: bool            # OPTION 2 sideslip shift
    kappa_idx: int         # observation index of the curvature
    pv0: int               # first preview entry of the observation
    n_preview: int
    pv_vmin: float         # preview spacing speed floor [m/s]
    pv_dt: float           # preview spacing [s]
    ant_rate: float        # rate-limit anticipation rate [rad/s] (0: off)
    ant_lag: float         # actuator lag allowed for by the anticipation [s]
    wheelbase_m: float
    kus: float             # understeer gradient K_us [rad s^2/m]
    dyn_floor: float       # low-speed floor of the yaw-dynamics model speed [m/s] (0: none)
    high_speed: float = 0.0   # above it eta falls as v_s/v and p as (v_s/v)^pole_exp [m/s] (0: constant gains)
    pole_exp: float = 0.0     # exponent of the pole's high-speed scaling


def smc_layer(eta: np.ndarray, delta: np.ndarray, control_period_s: float, limit_layer_rate: bool) -> np.ndarray:
    """Effective boundary layer [rad/s]: ``max(Delta, eta T_c)`` under the limit_layer_rate rule, else Delta."""
    return np.maximum(delta, eta * control_period_s) if limit_layer_rate else np.asarray(delta, dtype=np.float64)


def smc_law(design: DesignModel, layout: ObservationLayout, pole: Any, eta: Any, layer: Any, min_speed_mps: float,
            guard_band_mps: float, sideslip_shift: bool, anticipation_lag_s: float | None = None,
            dynamics_floor_mps: float = 0.0, high_speed_mps: float = 0.0, pole_speed_exponent: float = 0.0) -> SMCLaw:
    """``SMCLaw`` for poles p [rad/s], gains eta [rad/s^2] and effective layers [rad/s] (scalars or (R,) arrays,
    positive, checked by the caller); ``anticipation_lag_s`` [s] turns the rate-limit anticipation on (None: off);
    above ``high_speed_mps`` = v_s [m/s] (> 0) eta is scaled by v_s / v and p by (v_s / v)^``pole_speed_exponent``."""
    from vtrack_gym.vehicle.linear import understeer_gradient

    pole, eta, layer = (np.ascontiguousarray(np.asarray(a, dtype=np.float64).reshape(-1)) for a in (pole, eta, layer))
    k = np.array(smc_design_constants(design))
    return SMCLaw(np.array([layout.index(n) for n in SMC_SIGNALS], dtype=np.int64), k, pole, eta * k[7],
                  1.0 / layer, float(min_speed_mps), float(smc_singular_speed(design)), float(guard_band_mps),
                  bool(sideslip_shift), layout.index("curvature"), layout.preview.start, layout.n_preview,
                  float(layout.preview_min_speed_mps), float(layout.preview_dt_s),
                  0.0 if anticipation_lag_s is None else ANTICIPATION_RATE_FACTOR * design.max_road_wheel_rate_radps,
                  0.0 if anticipation_lag_s is None else float(anticipation_lag_s), float(design.wheelbase_m),
                  float(understeer_gradient(design)), float(dynamics_floor_mps), float(high_speed_mps),
                  float(pole_speed_exponent))


def smc_surface_and_law(k: Any, cf: Any, v: float, p_shift: bool, e_y: float, e_phi: float, e_y_dot: float,
                        e_phi_dot: float, v_y: float, r: float, rate_ref: float, acc_ref: float, f3s: float, f4s: float,
                        vs: float) -> tuple[float, float]:
    """``(sigma [rad/s], delta_eq [rad])``: the surface (27) and the law (31) without the switching term, with the
    coefficients ``cf`` at speed ``v`` [m/s] and the sideslip shift's f3, f4 at speed ``vs`` (the same ones unless
    the low-speed floor applies)."""
    lam, c1, c2, c3, f5, f6 = cf[0], cf[4], cf[5], cf[6], cf[7], cf[8]
    x1 = e_y - lam * e_phi
    x2 = e_y_dot - lam * e_phi_dot
    bracket = acc_ref * (1.0 + c2 * lam) - f5 * r - f6 * v_y + c1 * x2 + (c2 * v + c3) * e_phi_dot
    if p_shift:
        x3s = f3s * rate_ref / (vs * f4s)
        x3s_dot = f3s * acc_ref / (vs * f4s)
        sigma = e_phi_dot - c1 * (x1 + lam * x3s) - c2 * x2 - c3 * (e_phi - x3s)
        bracket = bracket - (c3 - c1 * lam) * x3s_dot
    else:
        sigma = e_phi_dot - c1 * x1 - c2 * x2 - c3 * e_phi
    return sigma, k[7] * bracket


_guarded_speed = kernel(guarded_speed)
_smc_coefficients = kernel(smc_coefficient_values)
_smc_surface_and_law = kernel(smc_surface_and_law)


@kernel
def smc_row(law: SMCLaw, obs: np.ndarray, i: int) -> tuple[float, float, bool]:
    """SMC on observation row ``i``: (road-wheel angle [rad], sigma [rad/s], speed was guarded)."""
    r = i if law.pole.shape[0] > 1 else 0
    idx = law.idx
    v_clamped = max(float(obs[i, idx[0]]), law.min_speed)
    v = _guarded_speed(v_clamped, law.v_star, law.guard)
    pole, eta_k = law.pole[r], law.eta_k[r]
    if law.high_speed > 0.0 and v_clamped > law.high_speed:   # high-speed gains: eta v_s / v, p (v_s / v)^exp
        ratio = law.high_speed / v_clamped
        eta_k *= ratio
        pole *= ratio ** law.pole_exp
    cf = _smc_coefficients(law.k, v, pole)
    e_phi_dot, rate_ref = float(obs[i, idx[4]]), float(obs[i, idx[7]])
    if law.ant_rate > 0.0:  # track the anticipated yaw rate v kappa_a (kappa_a: the anticipated steer's curvature)
        vx = max(float(obs[i, idx[0]]), 0.0)
        gain = law.wheelbase_m + law.kus * vx * vx
        dr = vx * rate_anticipation(obs, i, law.kappa_idx, law.pv0, law.n_preview, law.pv_vmin, law.pv_dt, vx, gain,
                                    law.ant_rate, law.ant_lag) / gain
        rate_ref += dr
        e_phi_dot -= dr
    f3s, f4s, vs = cf[1], cf[2], v
    ff = 0.0
    if law.dyn_floor > v:  # the yaw dynamics at the floor speed; steady state and sideslip shift at v
        vd = _guarded_speed(law.dyn_floor, law.v_star, law.guard)
        cfd = _smc_coefficients(law.k, vd, pole)
        vy_ss = rate_ref * (law.k[1] - law.k[0] * v * v) / law.k[2]
        ff = law.k[7] * ((cfd[7] - cf[7]) * rate_ref + (cfd[8] - cf[8]) * vy_ss)
        cf, v = cfd, vd
    sigma, delta_eq = _smc_surface_and_law(law.k, cf, v, law.shift, float(obs[i, idx[1]]), float(obs[i, idx[2]]),
                                           float(obs[i, idx[3]]), e_phi_dot, float(obs[i, idx[5]]),
                                           float(obs[i, idx[6]]), rate_ref, float(obs[i, idx[8]]), f3s, f4s, vs)
    delta_eq += ff
    z = sigma * law.inv_layer[r]
    sat = 1.0 if z > 1.0 else (-1.0 if z < -1.0 else z)
    return delta_eq - eta_k * sat, sigma, vs != v_clamped


@kernel
def smc_rows(law: SMCLaw, obs: np.ndarray, delta: np.ndarray, sigma: np.ndarray) -> int:
    """``smc_row`` for every row of ``obs`` into ``delta`` [rad] and ``sigma`` [rad/s]; returns the number of
    rows whose speed was guarded."""
    guarded = 0
    for i in range(obs.shape[0]):
        delta[i], sigma[i], g = smc_row(law, obs, i)
        guarded += g
    return guarded


# ---------------------------------------------------------------------------------------- gain schedules
@kernel(inline=True)
def schedule_locate(speeds: np.ndarray, v: float) -> tuple[int, float]:
    """Grid interval ``s`` and fraction ``t`` in [0, 1] of speed ``v`` [m/s] on the grid ``speeds`` (S,) [m/s]
    (the speed clamped to the grid's ends)."""
    s_last = speeds.shape[0] - 2
    vc = min(max(v, speeds[0]), speeds[s_last + 1])
    s = np.searchsorted(speeds, vc, side="right") - 1
    s = 0 if s < 0 else (s_last if s > s_last else s)
    return s, (vc - speeds[s]) / (speeds[s + 1] - speeds[s])


@kernel
def schedule_dot(speeds: np.ndarray, table: np.ndarray, slopes: np.ndarray, v: float, z: np.ndarray) -> float:
    """``row(v) . z`` of a gain schedule: rows ``table`` (S, W) on ``speeds`` (S,) [m/s], ``slopes`` (S - 1, W)
    their differences; the speed is clamped to the grid and each entry interpolated linearly."""
    s, t = schedule_locate(speeds, v)
    acc = 0.0
    for c in range(table.shape[1]):
        acc += (table[s, c] + t * slopes[s, c]) * z[c]
    return acc


@kernel
def schedule_row(speeds: np.ndarray, table: np.ndarray, slopes: np.ndarray, v: float, out: np.ndarray) -> None:
    """The gain row at speed ``v`` [m/s] into ``out`` (W,) (arguments as ``schedule_dot``'s)."""
    s, t = schedule_locate(speeds, v)
    for c in range(table.shape[1]):
        out[c] = table[s, c] + t * slopes[s, c]


# ------------------------------------------------------------------------------------------------------ MPC
class MPCLaw(NamedTuple):
    """Parameters of the speed-scheduled MPC law for R gain tables (R = 1: one controller)."""

    idx: np.ndarray     # int64 (11,): observation indices of MPC_SIGNALS
    pv0: int            # first preview entry of the observation
    pv1: int            # one past the last preview entry
    pv_vmin: float      # preview spacing speed floor [m/s]
    pv_dt: float        # preview spacing [s]
    preview: bool       # use the curvature preview for d
    n_out: int          # measured outputs (2: e_y, e_phi; 1: e_y)
    ts: float           # MPC sample time [s]
    n_hold: float       # env steps per MPC sample
    max_du: float       # |Delta u| limit per sample [rad] (inf: none)
    max_steer: float    # |u| limit [rad]
    speeds: np.ndarray  # (S,) gain-schedule grid [m/s]
    tables: np.ndarray  # (R, S, W) run-time gain rows
    slopes: np.ndarray  # (R, S - 1, W) differences of consecutive rows
    ant_rate: float     # rate-limit anticipation rate [rad/s] (0: off)
    ant_lag: float      # actuator lag allowed for by the anticipation [s]
    wheelbase_m: float  # l [m]
    kus: float          # understeer gradient K_us [rad s^2/m]
    lf_m: float         # CG to front axle a [m]
    slip_max: float     # front slip-angle bound [rad] (inf: none)


def mpc_law(layout: ObservationLayout, speeds: np.ndarray, tables: np.ndarray, *, preview: bool, n_out: int,
            sample_time_s: float, n_hold: int, max_du: float, max_steer: float,
            design: DesignModel | None = None, anticipation_lag_s: float | None = None,
            front_slip_max_rad: float = math.inf) -> MPCLaw:
    """``MPCLaw`` for run-time gain tables (S, W) or (R, S, W) on ``speeds`` (S,) [m/s]; ``design`` and
    ``anticipation_lag_s`` [s] turn the rate-limit anticipation on (None: off)."""
    from vtrack_gym.vehicle.linear import understeer_gradient

    on = design is not None and anticipation_lag_s is not None
    speeds = np.ascontiguousarray(speeds, dtype=np.float64)
    tables = np.ascontiguousarray(np.asarray(tables, dtype=np.float64).reshape(-1, *np.shape(tables)[-2:]))
    return MPCLaw(np.array([layout.index(n) for n in MPC_SIGNALS], dtype=np.int64), layout.preview.start,
                  layout.preview.stop, float(layout.preview_min_speed_mps), float(layout.preview_dt_s), bool(preview),
                  int(n_out), float(sample_time_s), float(n_hold), float(max_du), float(max_steer), speeds, tables,
                  np.ascontiguousarray(np.diff(tables, axis=1)),
                  MPC_ANTICIPATION_RATE_FACTOR * design.max_road_wheel_rate_radps if on else 0.0,
                  float(anticipation_lag_s) if on else 0.0, float(design.wheelbase_m) if on else 0.0,
                  float(understeer_gradient(design)) if on else 0.0,
                  float(design.cg_to_front_axle_m) if design is not None else 0.0,
                  float(front_slip_max_rad) if design is not None else math.inf)


@kernel
def mpc_disturbance(law: MPCLaw, obs: np.ndarray, i: int) -> float:
    """d(k) [rad/s^2] of row ``i``: yaw_acc_ref, with preview its average over the first preview interval."""
    idx = law.idx
    if not law.preview:
        return float(obs[i, idx[7]])
    v = max(float(obs[i, idx[0]]), 0.0)
    x1 = max(v, law.pv_vmin) * law.pv_dt
    return float(obs[i, idx[7]]) + v * v * ((float(obs[i, law.pv0]) - float(obs[i, idx[9]])) / x1
                                             - float(obs[i, idx[10]]))


@kernel
def mpc_curvature_shift(law: MPCLaw, obs: np.ndarray, i: int) -> float:
    """Rate-limit anticipation of row ``i`` as a curvature shift dkappa [1/m] (``rate_anticipation`` / (l + K_us
    v^2)); exactly 0.0 when off or while the previewed steady-state steer is reachable at the actuator's rate."""
    if law.ant_rate <= 0.0:
        return 0.0
    idx = law.idx
    v = max(float(obs[i, idx[0]]), 0.0)
    gain = law.wheelbase_m + law.kus * v * v
    if gain <= 0.0:
        return 0.0
    return rate_anticipation(obs, i, idx[9], law.pv0, law.pv1 - law.pv0, law.pv_vmin, law.pv_dt, v, gain,
                             law.ant_rate, law.ant_lag) / gain


@kernel
def mpc_reference(law: MPCLaw, obs: np.ndarray, i: int) -> tuple[float, float, float]:
    """(e_phi_dot [rad/s], d [rad/s^2], kappa [1/m]) of row ``i`` relative to the anticipated reference: the
    path's curvature at the car shifted by ``mpc_curvature_shift`` (the observed values when the shift is 0)."""
    idx = law.idx
    epd, d0, kap = float(obs[i, idx[6]]), mpc_disturbance(law, obs, i), float(obs[i, idx[9]])
    dk = mpc_curvature_shift(law, obs, i)
    if dk != 0.0:
        v = max(float(obs[i, idx[0]]), 0.0)
        epd -= v * dk
        kap += dk
        if law.preview:  # the step average from the shifted curvature to the first preview sample
            d0 -= v * v * dk / (max(v, law.pv_vmin) * law.pv_dt)
    return epd, d0, kap


@kernel
def mpc_initial_rows(law: MPCLaw, obs: np.ndarray, state: np.ndarray) -> None:
    """Initial memory of every row into ``state`` (N, 9): x_m(k-1) = x_m(k), u(k-1) = the observed road-wheel
    angle (clipped), d(k-1) = d(k), next call samples."""
    idx = law.idx
    for i in range(obs.shape[0]):
        epd, d0, _ = mpc_reference(law, obs, i)
        for j in range(5):
            state[i, j] = obs[i, idx[1 + j]]
        state[i, 5] = epd
        state[i, 6] = min(max(float(obs[i, idx[8]]), -law.max_steer), law.max_steer)
        state[i, 7] = d0
        state[i, 8] = 0.0


@kernel
def mpc_row(law: MPCLaw, obs: np.ndarray, i: int, st: np.ndarray, z: np.ndarray) -> float:
    """MPC on observation row ``i`` with memory ``st`` (9,), updated in place; ``z`` (W,) scratch. Returns the
    road-wheel angle u(k) [rad] (held between samples)."""
    if st[8] >= 0.5:
        st[8] -= 1.0
        return st[6]
    idx = law.idx
    r = i if law.tables.shape[0] > 1 else 0
    half = 0.5 * law.ts
    width = law.tables.shape[2]
    vy, yr, ey, eyd, ep = float(obs[i, idx[1]]), float(obs[i, idx[2]]), float(obs[i, idx[3]]), \
        float(obs[i, idx[4]]), float(obs[i, idx[5]])
    v_x = float(obs[i, idx[0]])
    epd, d0, kap = mpc_reference(law, obs, i)
    z[0] = half * (vy + st[0])
    z[1] = vy - st[0]
    z[2] = half * (yr + st[1])
    z[3] = yr - st[1]
    z[4] = ey - st[2]
    z[5] = eyd - st[3]
    z[6] = (ep - st[4] + math.pi) % TWO_PI - math.pi
    z[7] = epd - st[5]
    z[8] = ey
    j = 9
    if law.n_out == 2:
        z[9] = ep
        j = 10
    z[j] = d0 - st[7]
    z[j + 1] = kap
    for q in range(law.pv1 - law.pv0):
        z[j + 2 + q] = float(obs[i, law.pv0 + q])
    z[width - 1] = float(obs[i, idx[10]])
    acc = schedule_dot(law.speeds, law.tables[r], law.slopes[r], v_x, z)
    du = -acc
    du = law.max_du if du > law.max_du else (-law.max_du if du < -law.max_du else du)
    u = st[6] + du
    if law.slip_max < math.inf and v_x > 1.0:  # no steer beyond the front tyres' peak slip angle
        kin = (vy + law.lf_m * yr) / v_x   # direction of the front axle's velocity [rad]
        u = kin + law.slip_max if u > kin + law.slip_max else (kin - law.slip_max if u < kin - law.slip_max else u)
    u = law.max_steer if u > law.max_steer else (-law.max_steer if u < -law.max_steer else u)
    st[0], st[1], st[2], st[3], st[4], st[5] = vy, yr, ey, eyd, ep, epd
    st[6] = u
    st[7] = d0
    st[8] = law.n_hold - 1.0
    return u


@kernel
def mpc_rows(law: MPCLaw, obs: np.ndarray, state: np.ndarray, delta: np.ndarray) -> None:
    """``mpc_row`` for every row of ``obs`` (memory ``state`` (N, 9) updated in place) into ``delta`` [rad]."""
    z = np.empty(law.tables.shape[2])
    for i in range(obs.shape[0]):
        delta[i] = mpc_row(law, obs, i, state[i], z)
