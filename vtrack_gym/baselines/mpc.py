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

from vtrack_gym._ranges import documented, ranged, validate
from vtrack_gym.baselines.base import Policy, SpeedSchedule, hold_steps, require_choice
from vtrack_gym.baselines.linear_models import curvature_preview_operator, lateral_matrices, paper_model, zoh
from vtrack_gym.envs.observation import OBS, ObservationLayout
from vtrack_gym.vehicle.params import DesignModel

PAPER_WEIGHTS: tuple[float, ...] = (0.0015, 0.3626, 0.0152, 0.6179, 0.2788, 0.2453, 0.1527, 0.8068,
                                    0.0012, 0.0207, 0.7908, 0.7904)
"""Table 3 MPC weights w1..w12 (B1: on Delta x_m (8) and y, phi, e_y, e_phi)."""
INTERPRETATIONS = ("augmented_outputs", "siso_per_step")
"""B1 (paper-math 4.1, chosen) and A."""
OUTPUTS = {"augmented_outputs": (0, 2, 4, 6), "siso_per_step": (4,)}
"""Indices in x_m of the outputs y of each interpretation."""
RELATIVE = (0, 2)
"""x_m indices (y, phi) whose output value is zero in the car-fixed frame (relative outputs)."""
TWO_PI = 2.0 * math.pi


@documented
@dataclass(frozen=True)
class MPCConfig:
    """Paper MPC parameters.

    weights: w1..w12 (>= 0). input_weight: w of W2 = w I.
    prediction_horizon N_p; control_horizon N_c; sample_time_s T_s [s].
    interpretation: "augmented_outputs" (B1) or "siso_per_step" (A, needs N_p = len(weights)).
    use_preview: preview psi_ref_ddot from the curvature preview. rate_limit: clip Delta_u to the steering rate.
    min_speed_mps / max_speed_mps / n_speeds: the gain-schedule grid [m/s].
    """

    weights: tuple[float, ...] = PAPER_WEIGHTS
    input_weight: float = ranged(0.1, gt=0.0, le=1e6)
    prediction_horizon: int = ranged(50, ge=1, le=60, integer=True)
    control_horizon: int = ranged(5, ge=1, le="prediction_horizon", integer=True)
    sample_time_s: float = ranged(0.02, ge=0.001, le=0.2, unit="s")
    interpretation: str = "augmented_outputs"
    use_preview: bool = True
    rate_limit: bool = True
    min_speed_mps: float = ranged(1.0, ge=0.5, le=80.0, unit="m/s")
    max_speed_mps: float = ranged(45.0, gt="min_speed_mps", le=80.0, unit="m/s")
    n_speeds: int = ranged(60, ge=2, le=100, integer=True)

    def __post_init__(self) -> None:
        validate(self)
        if len(self.weights) != 12:
            raise ValueError(f"MPCConfig.weights must have 12 entries (got {len(self.weights)})")
        if any(not (isinstance(w, (int, float)) and math.isfinite(w) and w >= 0.0) for w in self.weights):
            raise ValueError(f"MPCConfig.weights must be finite numbers >= 0 (got {self.weights})")
        object.__setattr__(self, "weights", tuple(float(w) for w in self.weights))
        require_choice(self, "interpretation", INTERPRETATIONS)
        if self.interpretation == "siso_per_step" and self.prediction_horizon != len(self.weights):
            raise ValueError("MPCConfig.prediction_horizon must equal len(weights) = 12 for interpretation "
                             f"'siso_per_step' (got {self.prediction_horizon})")


MPC_PRESETS: dict[str, MPCConfig] = {
    "paper": MPCConfig(),
    "hand": MPCConfig(input_weight=100.0),
    "paper_siso": MPCConfig(interpretation="siso_per_step", prediction_horizon=12, control_horizon=5),
}


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


@dataclass(frozen=True)
class GainTable:
    """Exact gains on the speed grid: speeds (S,) [m/s], K_x (S, n), K_d (S, N_p), K_r (S, q) and the folded
    run-time rows (S, width) used by ``MPC``."""

    speeds: np.ndarray
    kx: np.ndarray
    kd: np.ndarray
    kr: np.ndarray
    runtime: np.ndarray


@functools.lru_cache(maxsize=32)
def gain_table(design: DesignModel, config: MPCConfig, layout: ObservationLayout = OBS) -> GainTable:
    """Gains on ``np.geomspace(min_speed, max_speed, n_speeds)``; cached per (design, config, layout).

    Run-time row = [K_x on Delta x_m (8), K_x on the measured outputs (e_y, e_phi for B1; e_y for A), K_d[0],
    folded preview gains (P + 2, on (kappa(0), preview..., kappa'(0)); zero without preview)].
    """
    speeds = np.geomspace(config.min_speed_mps, config.max_speed_mps, config.n_speeds)
    outputs = OUTPUTS[config.interpretation]
    measured = [8 + j for j, xi in enumerate(outputs) if xi not in RELATIVE]
    npred, ts = config.prediction_horizon, config.sample_time_s
    kxs, kds, krs, rows = [], [], [], []
    for v in speeds:
        g = mpc_gains(design, float(v), config)
        kxs.append(g.kx)
        kds.append(g.kd)
        krs.append(g.kr)
        preview = np.zeros(layout.n_preview + 2)
        if config.use_preview and npred > 1:
            kap, _ = curvature_preview_operator(layout, float(v), v * ts * np.arange(npred + 1))
            slope = (v / ts) * np.diff(kap, axis=0)            # d(k+i) - c, i = 0..N_p-1, rows on p
            kd_next = np.append(g.kd[1:], 0.0)
            preview = (g.kd - kd_next)[1:] @ (slope[1:] - slope[0])
        rows.append(np.concatenate((g.kx[:8], g.kx[measured], g.kd[:1], preview)))
    table = GainTable(speeds, np.array(kxs), np.array(kds), np.array(krs), np.array(rows))
    for arr in (table.speeds, table.kx, table.kd, table.kr, table.runtime):
        arr.setflags(write=False)
    return table


class MPC(Policy):
    """The paper's MPC (paper-math 4) with precomputed speed-scheduled gains; see the module docstring."""

    name: ClassVar[str] = "mpc"
    PRESETS: ClassVar[dict[str, MPCConfig]] = MPC_PRESETS
    FILE_PRESETS: ClassVar[tuple[str, ...]] = ("default", "tuned")
    config_type: ClassVar[type] = MPCConfig
    state_size = 9

    @classmethod
    def _file_preset(cls, preset: str) -> MPCConfig:
        from vtrack_gym.baselines.preset_files import tuned_config

        return tuned_config(cls.name)

    def __init__(self, design: DesignModel, config: MPCConfig | None = None, layout: ObservationLayout = OBS,
                 control_period_s: float = 0.01) -> None:
        super().__init__(design, config, layout, control_period_s)
        cfg: MPCConfig = self.config
        self.n_hold = hold_steps(cfg.sample_time_s, self.control_period_s, "MPCConfig")
        self.table = gain_table(design, cfg, layout)
        self.schedule = SpeedSchedule(self.table.speeds, self.table.runtime)
        self._ts = cfg.sample_time_s
        self._max_du = design.max_road_wheel_rate_radps * cfg.sample_time_s if cfg.rate_limit else math.inf
        self._n_out = len([xi for xi in OUTPUTS[cfg.interpretation] if xi not in RELATIVE])
        self._preview = cfg.use_preview
        L = layout
        self._idx = (L.index("v_x"), L.index("v_y"), L.index("yaw_rate"), L.index("e_y"), L.index("e_y_dot"),
                     L.index("e_phi"), L.index("e_phi_dot"), L.index("yaw_acc_ref"), L.index("road_wheel_angle"),
                     L.index("curvature"), L.index("curvature_rate"))
        self._pv = (layout.preview.start, layout.preview.stop)
        self._pv_vmin, self._pv_dt = layout.preview_min_speed_mps, layout.preview_dt_s

    # ----------------------------------------------------------------------------------------- memory
    def _initial_state_single(self, row: list[float]) -> list[float]:
        _, ivy, ir, iey, ieyd, iep, iepd, _, idel, _, _ = self._idx
        u = min(max(row[idel], -self.max_steer_rad), self.max_steer_rad)
        return [row[ivy], row[ir], row[iey], row[ieyd], row[iep], row[iepd], u, self._d_now_single(row), 0.0]

    def _initial_state_batch(self, obs: np.ndarray) -> np.ndarray:
        _, ivy, ir, iey, ieyd, iep, iepd, _, idel, _, _ = self._idx
        st = np.zeros((obs.shape[0], 9))
        st[:, :6] = obs[:, [ivy, ir, iey, ieyd, iep, iepd]]
        st[:, 6] = np.clip(obs[:, idel], -self.max_steer_rad, self.max_steer_rad)
        st[:, 7] = self._d_now_batch(obs)
        return st

    def _d_now_single(self, row: list[float]) -> float:
        """d(k) [rad/s^2]: yaw_acc_ref, with preview its average over the first preview interval (see docstring)."""
        iv, _, _, _, _, _, _, iacc, _, ik, ikr = self._idx
        if not self._preview:
            return row[iacc]
        v = max(row[iv], 0.0)
        x1 = max(v, self._pv_vmin) * self._pv_dt
        return row[iacc] + v * v * ((row[self._pv[0]] - row[ik]) / x1 - row[ikr])

    def _d_now_batch(self, obs: np.ndarray) -> np.ndarray:
        iv, _, _, _, _, _, _, iacc, _, ik, ikr = self._idx
        if not self._preview:
            return obs[:, iacc].copy()
        v = np.maximum(obs[:, iv], 0.0)
        x1 = np.maximum(v, self._pv_vmin) * self._pv_dt
        return obs[:, iacc] + v * v * ((obs[:, self._pv[0]] - obs[:, ik]) / x1 - obs[:, ikr])

    # ------------------------------------------------------------------------------------------ control
    def _act_single(self, row: list[float], state: list[float]) -> tuple[float, list[float]]:
        vy0, r0, ey0, eyd0, ep0, epd0, u_prev, d_prev, count = state
        if count >= 0.5:
            state[8] = count - 1.0
            return u_prev, state
        iv, ivy, ir, iey, ieyd, iep, iepd, _, _, ik, ikr = self._idx
        vy, r, ey, eyd, ep, epd = row[ivy], row[ir], row[iey], row[ieyd], row[iep], row[iepd]
        d0 = self._d_now_single(row)
        half = 0.5 * self._ts
        dep = (ep - ep0 + math.pi) % TWO_PI - math.pi
        z = [half * (vy + vy0), vy - vy0, half * (r + r0), r - r0, ey - ey0, eyd - eyd0, dep, epd - epd0, ey]
        if self._n_out == 2:
            z.append(ep)
        z.append(d0 - d_prev)
        z.append(row[ik])
        z.extend(row[self._pv[0]:self._pv[1]])
        z.append(row[ikr])
        du = -self.schedule.dot(row[iv], z)
        lim = self._max_du
        du = lim if du > lim else (-lim if du < -lim else du)
        u = u_prev + du
        m = self.max_steer_rad
        u = m if u > m else (-m if u < -m else u)
        return u, [vy, r, ey, eyd, ep, epd, u, d0, self.n_hold - 1.0]

    def _act_batch(self, obs: np.ndarray, state: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        iv, ivy, ir, iey, ieyd, iep, iepd, _, _, ik, ikr = self._idx
        n = obs.shape[0]
        now = obs[:, [ivy, ir, iey, ieyd, iep, iepd]]
        prev = state[:, :6]
        half = 0.5 * self._ts
        z = np.empty((n, self.schedule.width))
        z[:, 0] = half * (now[:, 0] + prev[:, 0])
        z[:, 1] = now[:, 0] - prev[:, 0]
        z[:, 2] = half * (now[:, 1] + prev[:, 1])
        z[:, 3] = now[:, 1] - prev[:, 1]
        z[:, 4] = now[:, 2] - prev[:, 2]
        z[:, 5] = now[:, 3] - prev[:, 3]
        z[:, 6] = np.mod(now[:, 4] - prev[:, 4] + math.pi, TWO_PI) - math.pi
        z[:, 7] = now[:, 5] - prev[:, 5]
        z[:, 8] = now[:, 2]
        j = 9
        if self._n_out == 2:
            z[:, 9] = now[:, 4]
            j = 10
        d0 = self._d_now_batch(obs)
        z[:, j] = d0 - state[:, 7]
        z[:, j + 1] = obs[:, ik]
        z[:, j + 2:-1] = obs[:, self._pv[0]:self._pv[1]]
        z[:, -1] = obs[:, ikr]
        du = np.clip(-self.schedule.dot_batch(obs[:, iv], z), -self._max_du, self._max_du)
        u_new = np.clip(state[:, 6] + du, -self.max_steer_rad, self.max_steer_rad)
        hold = state[:, 8] >= 0.5
        new = np.empty_like(state)
        new[:, :6] = now
        new[:, 6] = u_new
        new[:, 7] = d0
        new[:, 8] = self.n_hold - 1.0
        new[hold] = state[hold]
        new[hold, 8] -= 1.0
        return new[:, 6], new
