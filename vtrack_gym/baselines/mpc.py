"""The paper's MPC steering controller (paper-math section 4): corrected eq. (9), Wang's augmented incremental
form, closed-form unconstrained receding-horizon gains, scheduled on speed.

Model (4.2): corrected A9, B9, D9 (``linear_models.paper_model``) in x_m = (y, v_y, phi, r, e_y, e_y_dot,
e_phi, e_phi_dot), ZOH at ``sample_time_s`` T_s (default 0.02 s) -> A_m, B_m, D_m (d = psi_ref_ddot
[rad/s^2]). Augmented state ``x~ = [x_m(k) - x_m(k-1); y(k)]``::

    A = [[A_m, 0], [C_m A_m, I_q]],  B = [B_m; C_m B_m],  D = [D_m; C_m D_m]

Interpretations (4.1): ``"augmented_outputs"`` (B1, default): y = (y, phi, e_y, e_phi), q = 4, all 12 entries
of x~ weighted, W1 = I_Np kron diag(w1..w12); ``"siso_per_step"`` (A): y = e_y, q = 1, the 12 weights are
per-step weights on the predicted e_y (so N_p = 12). W2 = w I_Nc. Gains (4.3)::

    K_mpc = e1' (Phi' W1 Phi + W2)^-1 Phi' W1,  K_x = K_mpc F,  K_d = K_mpc tau,  K_r = K_mpc (1 kron [0; I_q])
    Delta_u(k) = -K_x x~(k) - K_d Delta_D(k)        (r_y = 0, relative outputs)

Measurement rules:

* Relative outputs (4.3 CHOICE): the output part of x~ is (0, 0, e_y, e_phi) (y, phi measured in a frame
  attached to the car at sample k). The increments are measured: Delta y = T_s (v_y(k) + v_y(k-1))/2 and
  Delta phi = T_s (r(k) + r(k-1))/2 (trapezoidal integrals of the body-frame lateral speed and yaw rate; the
  observation holds no global pose); the other six are differences of the observation's v_y, r, e_y,
  e_y_dot, e_phi (wrapped), e_phi_dot with the values stored at the previous MPC sample.
* Disturbance preview (4.3): the paper-math recipe is d(k+i) = v^2 kappa'(s* + v i T_s) + a_x kappa. The
  observation only samples kappa (every 0.1 s of travel), so kappa is taken piecewise linear through
  (curvature, preview samples) (``linear_models.curvature_preview_operator``) and d over each MPC step is the
  step average of that interpolant: ``d(k+i) = v (kappa(q_{i+1}) - kappa(q_i)) / T_s + c``, q_i = v i T_s,
  with ``c = yaw_acc_ref - v^2 curvature_rate`` (the current a_x kappa term, held). This is consistent in the
  integral sense (the predicted psi_ref_dot at every sample equals v kappa of the interpolant), so a curvature
  STEP is predicted once and never counted twice (a central-difference kappa' smears a step over two preview
  intervals, half of it behind the car). d(k) is the same formula at i = 0; it is stored as d(k-1) for the next sample.
  With ``use_preview=False``: d(k) = yaw_acc_ref and Delta_D = [d(k) - d(k-1), 0, ..., 0]. Because
  ``K_d Delta_D`` is linear in (d(k) - d(k-1)) and in the preview vector, it is folded into precomputed gains.
  Measured (linear model, tests/test_mpc.py): the preview lowers max|e_y| on the R100 entry (18.5 vs 24.4 mm)
  but raises it at 120 km/h (R500 10.7 vs 7.3 mm; DLC proxy 53 vs 30 mm): with the Table-3 weights on the
  state increments, the optimum starts the manoeuvre early. paper-math reports the same trend (11 vs 7 mm).
* Speed scheduling (4.4): K_x, K_d, K_r and the folded preview gains are precomputed on
  ``np.geomspace(min_speed_mps, max_speed_mps, n_speeds)`` (default 1..45 m/s, 60 points) and interpolated
  linearly per entry; the speed is clamped to the grid.

Sample time vs control period: the MPC keeps the paper's T_s semantics. It recomputes every
``n_hold = round(T_s / T_c)`` env steps and holds its output in between (T_s must be an integer multiple of the
env's control period T_c; 0.02 s = 2 x 10 ms by default). ``sample_time_s = T_c`` re-discretises and
recomputes the gains at the control period (no hold).

Saturation / anti-windup: ``u(k) = clip(u(k-1) + clip(Delta_u, +-rate T_s), +-delta_max)`` with ``u(k-1)`` the
SATURATED value actually applied at the previous sample, rate = ``design.max_road_wheel_rate_radps`` (if
``rate_limit``) and delta_max = ``design.max_road_wheel_angle_rad``. The integrator in u therefore never winds
up. On the first call (or ``episode_start``) u(k-1) is the observation's road_wheel_angle, x_m(k-1) = x_m(k)
and d(k-1) = d(k).

Dense tracks (outside the paper; ``rate_anticipation``, ``front_slip_limit``, on by default, off in the ``paper``
and ``paper_siso`` presets): a centre-line sampled every 1 m or less keeps the curvature steps of arc/straight
junctions sharp, and the unconstrained gains then steer through a 15 m chicane or a 6 m kart chicane late and
overshoot into front-tyre saturation (off the road on benchmarks/own_tracks.py's hairpins, club and kart
circuits at 1 m, while 2 m files, whose spline rounds each step over about 3 m, lap). Two additions:

* rate-limit anticipation: the curvature at the car (and with it e_phi_dot = r - v kappa and d(k)) is shifted by
  ``laws.rate_anticipation`` / (l + K_us v^2), planned at ``MPC_ANTICIPATION_RATE_FACTOR`` x the actuator rate;
  exactly 0 while the previewed steady-state steer is reachable in time;
* front slip bound: ``|u - (v_y + a r) / v_x| <= front_slip_limit x mu F_zf / C_f`` (2 x 0.063 rad for the
  paper car, ``front_slip_bound``), no steer beyond the front tyres' peak (above 1 m/s).

Measured (default preset, env): LateralTracking-v0 bit-identical; DLC120-v0 max|e_y| unchanged (0.156 m), ITAE
1.716 -> 1.603 (the slip bound acts at the exit); own circuits at 0.5 / 1 / 2 m all lap (max|e_y| <= 0.87 m).

State per row (``state_size = 9``): v_y, r, e_y, e_y_dot, e_phi, e_phi_dot at the previous MPC sample, the
applied u(k-1) [rad], d(k-1) [rad/s^2] and the number of env steps left before the next MPC sample.

Presets:

* ``paper``: Table-3 weights, T_s = 0.02 s, N_p = 50, N_c = 5, w = 0.1 (the paper-math 4.5 choices; W2 is not
  given by the paper). Linear closed loop: max|e_y| 18.5 mm (11.11 m/s, R 100), 10.7 mm (33.33 m/s, R 500),
  53 mm (DLC proxy); spectral radii as paper-math 4.4. Its effective gains are high (K_x on Delta e_y = 8.2
  rad/m at 40 km/h): in the nonlinear env (LateralTracking-v0) a 30 ms actuator delay, or sensor noise at 0.5x
  the env's nominal level, makes it oscillate off the road.
* ``default`` / ``tuned``: the packaged GA result ``vtrack_gym/baselines/presets/mpc_tuned.json`` (the ``hand``
  fields with w1..w12 tuned on Case 1 by ``vtrack tune``; its provenance records the command).
* ``hand``: the same Table-3 weights with w = 100 (chosen from w in {0.1, 1, 10, 30, 100, 300}). Linear closed
  loop: 6.8 mm (R 100), 14.8 mm (R 500), 67 mm (DLC proxy), a 0.5 m offset settles in 0.8 s with peak delta
  0.09 rad; spectral radius <= 0.991 from 1 to 45 m/s. In the env it completes LateralTracking-v0 nominally
  (max|e_y| 0.027 m vs 0.088 m for ``paper``), with a 30 ms delay (0.028 m) and with 0.5x sensor noise
  (0.11 m), and DLC120-v0 (0.17 m).
* ``observer``: the ``default`` config with ``observer=True``: a Kalman filter (``vtrack_gym.baselines.observer``)
  estimates e_y, e_phi, v_y, r and the road-wheel angle from the noisy measurements (R from the env's declared
  sensor noise) and the law runs on the estimates. Any preset takes ``observer=True`` as an override.
* ``paper_siso``: interpretation A (N_p = 12). Tracks the curves to < 0.5 mm without the rate limit, but with
  the steering rate limit (default ``rate_limit=True``, as in any real actuator) a 0.5 m offset or the DLC
  proxy diverges in the linear model: the unconstrained gains do not know the rate limit. The same happens
  with ``sample_time_s = 0.01`` and the Table-3 weights.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from vtrack_gym.baselines.base import Policy, hold_steps
from vtrack_gym.baselines.configs import (  # noqa: F401  (re-exported: the MPC's config, presets and constants)
    INTERPRETATIONS,
    MPC_PRESETS,
    OUTPUTS,
    PAPER_WEIGHTS,
    RELATIVE,
    MPCConfig,
)
from vtrack_gym.baselines.laws import MPC_STATE_SIZE, mpc_initial_rows, mpc_law, mpc_rows
from vtrack_gym.baselines.linear_models import curvature_preview_operator, lateral_matrices, paper_model, zoh
from vtrack_gym.baselines.observer import ObserverOption
from vtrack_gym.baselines.preset_files import TunedPresets, observer_preset
from vtrack_gym.envs.observation import OBS, ObservationLayout
from vtrack_gym.vehicle.params import GRAVITY_MPS2, DesignModel


@dataclass(frozen=True)
class MPCModel:
    """Matrices of paper-math 4.2 at one speed (continuous A9/B9/D9, discrete A_m/B_m/D_m, augmented A/B/D,
    weighted-output selector C_t and the prediction matrices F, Phi, tau, plus W1's diagonal)."""

    a9: np.ndarray
    b9: np.ndarray
    d9: np.ndarray
    am: np.ndarray
    bm: np.ndarray
    dm: np.ndarray
    a: np.ndarray
    b: np.ndarray
    d: np.ndarray
    c_out: np.ndarray
    f: np.ndarray
    phi: np.ndarray
    tau: np.ndarray
    w1: np.ndarray


@dataclass(frozen=True)
class MPCGains:
    """First-row receding-horizon gains: K_x (n,), K_d (N_p,), K_r (q,)."""

    kx: np.ndarray
    kd: np.ndarray
    kr: np.ndarray


def mpc_model(design: DesignModel, v_x: float, config: MPCConfig) -> MPCModel:
    """All matrices of paper-math 4.2 at speed ``v_x`` [m/s]."""
    a9, b9, d9 = paper_model(design, v_x)
    am, bmd = zoh(a9, np.column_stack((b9, d9)), config.sample_time_s)
    bm, dm = bmd[:, 0], bmd[:, 1]
    outputs = OUTPUTS[config.interpretation]
    q = len(outputs)
    cm = np.zeros((q, 8))
    cm[np.arange(q), outputs] = 1.0
    n = 8 + q
    a = np.zeros((n, n))
    a[:8, :8] = am
    a[8:, :8] = cm @ am
    a[8:, 8:] = np.eye(q)
    b = np.concatenate((bm, cm @ bm))
    d = np.concatenate((dm, cm @ dm))
    npred, nc = config.prediction_horizon, config.control_horizon
    if config.interpretation == "augmented_outputs":
        c_out = np.eye(n)
        w1 = np.tile(np.asarray(config.weights), npred)
    else:
        c_out = np.zeros((1, n))
        c_out[0, 8] = 1.0
        w1 = np.asarray(config.weights, dtype=np.float64)
    r = c_out.shape[0]
    powers = [np.eye(n)]
    for _ in range(npred):
        powers.append(a @ powers[-1])
    cab = [c_out @ p @ b for p in powers]      # C A^i B, i = 0..N_p
    cad = [c_out @ p @ d for p in powers]
    f = np.vstack([c_out @ powers[i] for i in range(1, npred + 1)])
    phi = np.zeros((r * npred, nc))
    tau = np.zeros((r * npred, npred))
    for i in range(1, npred + 1):
        rows = slice(r * (i - 1), r * i)
        for j in range(1, i + 1):
            if j <= nc:
                phi[rows, j - 1] = cab[i - j]
            tau[rows, j - 1] = cad[i - j]
    return MPCModel(a9, b9, d9, am, bm, dm, a, b, d, c_out, f, phi, tau, w1)


def mpc_gains(design: DesignModel, v_x: float, config: MPCConfig) -> MPCGains:
    """K_x, K_d, K_r of paper-math 4.3 at speed ``v_x`` [m/s] (exact, no interpolation)."""
    mdl = mpc_model(design, v_x, config)
    phtw = mdl.phi.T * mdl.w1
    hess = phtw @ mdl.phi + config.input_weight * np.eye(config.control_horizon)
    k_mpc = np.linalg.solve(hess, phtw)[0]
    q = mdl.a.shape[0] - 8
    sel = np.zeros((mdl.a.shape[0], q))
    sel[8:, :] = np.eye(q)
    kr = k_mpc @ np.tile(mdl.c_out @ sel, (config.prediction_horizon, 1))
    return MPCGains(k_mpc @ mdl.f, k_mpc @ mdl.tau, kr)


def closed_loop_spectral_radius(design: DesignModel, v_x: float, config: MPCConfig) -> float:
    """Spectral radius of the MPC loop on a minimal realisation at constant speed ``v_x`` [m/s].

    Loop state: (v_y, r, e_y, e_phi) at samples k and k-1 and u(k-1); e_y_dot = v_y + v e_phi and
    e_phi_dot = r (straight road) as in the linear model; Delta y, Delta phi as measured by the controller
    (trapezoid). The uncontrollable integrators y, phi and the two invariants of the 8-state model are left out
    (they sit at 1 and feed nothing).
    """
    kx = mpc_gains(design, v_x, config).kx
    ts, v = config.sample_time_s, v_x
    # q = (v_y, r, e_y, e_phi); x_m(q) = (., v_y, ., r, e_y, v_y + v e_phi, e_phi, r)
    xm_of_q = np.zeros((8, 4))
    xm_of_q[1, 0] = xm_of_q[3, 1] = xm_of_q[4, 2] = xm_of_q[6, 3] = xm_of_q[7, 1] = 1.0
    xm_of_q[5, 0], xm_of_q[5, 3] = 1.0, v
    alat, blat = lateral_matrices(design, v_x)
    ac = np.zeros((4, 4))
    ac[:2, :2] = alat
    ac[2, 0], ac[2, 3], ac[3, 1] = 1.0, v, 1.0
    aq, bq = zoh(ac, np.concatenate((blat, [0.0, 0.0])), ts)   # q(k+1) = aq q + bq u
    # Delta u = -g_now q(k) - g_prev q(k-1)
    g_now = kx[:8] @ xm_of_q
    g_prev = -kx[:8] @ xm_of_q
    trap = np.zeros(4)
    trap[0] = kx[0] * 0.5 * ts
    trap[1] = kx[2] * 0.5 * ts
    g_now = g_now + trap
    g_prev = g_prev + trap
    outputs = OUTPUTS[config.interpretation]
    for j, xi in enumerate(outputs):
        if xi not in RELATIVE:
            g_now = g_now + kx[8 + j] * xm_of_q[xi]
    # z = (q(k), q(k-1), u(k-1)); u(k) = u(k-1) - g_now q(k) - g_prev q(k-1)
    m = np.zeros((9, 9))
    m[:4, :4] = aq - np.outer(bq, g_now)
    m[:4, 4:8] = -np.outer(bq, g_prev)
    m[:4, 8] = bq
    m[4:8, :4] = np.eye(4)
    m[8, :4] = -g_now
    m[8, 4:8] = -g_prev
    m[8, 8] = 1.0
    return float(np.max(np.abs(np.linalg.eigvals(m))))


def front_slip_bound(design: DesignModel, factor: float) -> float:
    """Front slip-angle bound [rad]: ``factor`` x mu F_zf / C_f (static front axle load F_zf = m g b / l [N], axle
    cornering stiffness C_f [N/rad]; the slip at which the linear tyre reaches the friction limit; a brush tyre
    peaks at 3x it). inf when ``factor`` is 0 (no bound)."""
    if factor <= 0.0:
        return math.inf
    fz_front = design.mass_kg * GRAVITY_MPS2 * design.cg_to_rear_axle_m / design.wheelbase_m
    return factor * design.friction_mu * fz_front / design.front_cornering_stiffness_npr


@dataclass(frozen=True)
class GainTable:
    """Exact gains on the speed grid: speeds (S,) [m/s], K_x (S, n), K_d (S, N_p), K_r (S, q) and the folded
    run-time rows (S, width) used by ``MPC``."""

    speeds: np.ndarray
    kx: np.ndarray
    kd: np.ndarray
    kr: np.ndarray
    runtime: np.ndarray


def speed_grid(config: MPCConfig) -> np.ndarray:
    """The gain-schedule speeds [m/s]: ``np.geomspace(min_speed_mps, max_speed_mps, n_speeds)``."""
    return np.geomspace(config.min_speed_mps, config.max_speed_mps, config.n_speeds)


def measured_outputs(config: MPCConfig) -> list[int]:
    """Indices in the augmented state of the measured (not car-relative) outputs."""
    return [8 + j for j, xi in enumerate(OUTPUTS[config.interpretation]) if xi not in RELATIVE]


def preview_slope_difference(layout: ObservationLayout, v: float, config: MPCConfig) -> np.ndarray | None:
    """(N_p - 1, n_preview + 2): d(k+i) - d(k), i = 1..N_p-1, as linear maps of (kappa(0), preview...,
    kappa'(0)) at speed ``v`` [m/s] (the step averages of the piecewise-linear curvature, see the module
    docstring); None without preview (or N_p = 1)."""
    npred, ts = config.prediction_horizon, config.sample_time_s
    if not (config.use_preview and npred > 1):
        return None
    kap, _ = curvature_preview_operator(layout, v, v * ts * np.arange(npred + 1))
    slope = (v / ts) * np.diff(kap, axis=0)            # d(k+i) - c, i = 0..N_p-1, rows on p
    return slope[1:] - slope[0]


@functools.lru_cache(maxsize=32)
def gain_table(design: DesignModel, config: MPCConfig, layout: ObservationLayout = OBS) -> GainTable:
    """Gains on ``np.geomspace(min_speed, max_speed, n_speeds)``; cached per (design, config, layout).

    Run-time row = [K_x on Delta x_m (8), K_x on the measured outputs (e_y, e_phi for B1; e_y for A), K_d[0],
    folded preview gains (P + 2, on (kappa(0), preview..., kappa'(0)); zero without preview)].
    """
    speeds = speed_grid(config)
    measured = measured_outputs(config)
    kxs, kds, krs, rows = [], [], [], []
    for v in speeds:
        g = mpc_gains(design, float(v), config)
        kxs.append(g.kx)
        kds.append(g.kd)
        krs.append(g.kr)
        preview = np.zeros(layout.n_preview + 2)
        slope_diff = preview_slope_difference(layout, float(v), config)
        if slope_diff is not None:
            kd_next = np.append(g.kd[1:], 0.0)
            preview = (g.kd - kd_next)[1:] @ slope_diff
        rows.append(np.concatenate((g.kx[:8], g.kx[measured], g.kd[:1], preview)))
    table = GainTable(speeds, np.array(kxs), np.array(kds), np.array(krs), np.array(rows))
    for arr in (table.speeds, table.kx, table.kd, table.kr, table.runtime):
        arr.setflags(write=False)
    return table


class MPC(ObserverOption, TunedPresets, Policy):
    """The paper's MPC (paper-math 4) with precomputed speed-scheduled gains; see the module docstring.

    The law itself is ``vtrack_gym.baselines.laws.mpc_row`` (compiled); ``self.law`` holds its parameters.
    """

    name: ClassVar[str] = "mpc"
    PRESETS: ClassVar[dict[str, MPCConfig]] = MPC_PRESETS
    config_type: ClassVar[type] = MPCConfig
    state_size = MPC_STATE_SIZE

    FILE_PRESETS: ClassVar[tuple[str, ...]] = ("default", "tuned", "observer")

    def __init__(self, design: DesignModel, config: MPCConfig | None = None, layout: ObservationLayout = OBS,
                 control_period_s: float = 0.01, tables: np.ndarray | None = None,
                 noise_std: tuple[float, ...] | None = None) -> None:
        """``tables``: run-time gain rows (R, S, W) on the config's speed grid to use instead of the config's
        own (one table per observation row, as in the GA's populations; ``gain_table(...).runtime`` layout).
        ``noise_std``: the env's declared sensor noise, the observer's R (``observer.declared_noise_std``)."""
        super().__init__(design, config, layout, control_period_s)
        cfg: MPCConfig = self.config
        self.n_hold = hold_steps(cfg.sample_time_s, self.control_period_s, "MPCConfig")
        self.table = gain_table(design, cfg, layout)
        max_du = design.max_road_wheel_rate_radps * cfg.sample_time_s if cfg.rate_limit else math.inf
        n_out = len(measured_outputs(cfg))
        self.law = mpc_law(layout, self.table.speeds, self.table.runtime if tables is None else tables,
                           preview=cfg.use_preview, n_out=n_out, sample_time_s=cfg.sample_time_s, n_hold=self.n_hold,
                           max_du=max_du, max_steer=self.max_steer_rad, design=design,
                           anticipation_lag_s=cfg.actuator_lag_s if cfg.rate_anticipation else None,
                           front_slip_max_rad=front_slip_bound(design, cfg.front_slip_limit))
        self._attach_observer(noise_std)

    @classmethod
    def _file_preset(cls, preset: str) -> MPCConfig:
        """``default``/``tuned``: the packaged GA result; ``observer``: the same with the Kalman filter."""
        return observer_preset(cls.name, preset)

    def _law_initial_state(self, obs: np.ndarray) -> np.ndarray:
        state = np.empty((obs.shape[0], MPC_STATE_SIZE))
        mpc_initial_rows(self.law, obs, state)
        return state

    def _law_batch(self, obs: np.ndarray, state: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        delta = np.empty(obs.shape[0])
        mpc_rows(self.law, obs, state, delta)
        return delta, state
