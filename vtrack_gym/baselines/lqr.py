"""LQR steering on Rajamani's error model with curvature feedforward (classic peer; paper-math 3.2).

Model: x_e = (e_y [m], e_y_dot [m/s], e_phi [rad], e_phi_dot [rad/s]), ``x_e' = A4 x_e + B4 delta + ...``
(``linear_models.error_model``), ZOH-discretised at the env's control period T_c. Gains: discrete LQR
``K(v)`` from the DARE with ``Q = diag(q_e_y, q_e_y_dot, q_e_phi, q_e_phi_dot)`` and ``R = r_delta``,
precomputed on ``np.geomspace(min_speed_mps, max_speed_mps, n_speeds)`` and interpolated per entry (speed
clamped to the grid).

Law (Rajamani, Vehicle Dynamics and Control, 3.2-3.3, with axle stiffnesses)::

    delta = -K x_e + delta_ff,   delta_ff = delta_ss + k3 e_phi,ss
    delta_ss = kappa (l + K_us v^2),   e_phi,ss = -beta_ss = -kappa (C_ar a2 l - m a1 v^2)/(C_ar l)

i.e. the steady-state steer plus the term that cancels the state feedback's reaction to the unavoidable
steady-state heading error (k3 = K[2]), so that e_y,ss = 0 on a constant curve. kappa is the observation's
curvature, or (``feedforward_lead_s`` > 0) the preview curvature that far ahead in time (to compensate the
steering actuator lag). Measurements: e_y, e_y_dot, e_phi, e_phi_dot straight from the observation.

Rate-limit anticipation (``rate_anticipation``, default on): ``laws.rate_anticipation`` is added to delta. It
is exactly 0 while the steady-state steer along the curvature preview stays reachable at the actuator's rate
limit (every paper scenario); before a curvature change the actuator cannot follow in time (a 6 m hairpin or an
S-bend at 25 km/h: 0.5-1 rad of steer at 0.87 rad/s) it starts the steer early, so that the rate-limited ramp is
centred on the change instead of starting at it.

The road-wheel angle is clipped to +-max_road_wheel_angle_rad; the controller is stateless (rate limits are
left to the actuator).

Default (``LQRConfig()``): Q = diag(1, 1, 10, 1), R = 30, feedforward lead 0.08 s (compensates the env's 30 ms
steering lag plus the yaw-response lag). Chosen by a 400-point random search on the nonlinear env's
DLC120-v0 (seed 0; the 0.8 g manoeuvre spun out with 136 of the 400 weight sets, among them the stiffer
Q = diag(10, 0.1, 10, 0.1), R = 10): completed with max|e_y| 0.17 m; LateralTracking-v0 0.08 m. Linear closed
loop (ideal actuator, where the lead costs a little): max|e_y| 7.8 mm (11.11 m/s, R 100), 4.7 mm (33.33 m/s,
R 500), 20 mm (DLC proxy); a 0.5 m offset is removed without overshoot with peak delta 0.08 rad.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import ClassVar, NamedTuple

import numpy as np

from vtrack_gym._jit import kernel
from vtrack_gym._ranges import documented, ranged, validate
from vtrack_gym.baselines.base import Policy, SpeedSchedule
from vtrack_gym.baselines.laws import ANTICIPATION_RATE_FACTOR, rate_anticipation, schedule_dot
from vtrack_gym.baselines.linear_models import error_model, sideslip_gain, understeer_gradient, zoh
from vtrack_gym.envs.observation import OBS, ObservationLayout
from vtrack_gym.vehicle.params import DesignModel


@documented
@dataclass(frozen=True)
class LQRConfig:
    """LQR weights and schedule.

    q_e_y [1/m^2], q_e_y_dot [s^2/m^2], q_e_phi [1/rad^2], q_e_phi_dot [s^2/rad^2]: state weights.
    r_delta [1/rad^2]: steering weight.
    feedforward: add delta_ff. feedforward_lead_s: preview time of the feedforward curvature [s].
    rate_anticipation: add the rate-limit anticipation (``laws.rate_anticipation``).
    actuator_lag_s: the steering actuator's lag the anticipation allows for [s].
    min_speed_mps / max_speed_mps / n_speeds: gain-schedule grid.
    """

    q_e_y: float = ranged(1.0, ge=0.0, le=1e6, unit="1/m^2")
    q_e_y_dot: float = ranged(1.0, ge=0.0, le=1e6, unit="s^2/m^2")
    q_e_phi: float = ranged(10.0, ge=0.0, le=1e6, unit="1/rad^2")
    q_e_phi_dot: float = ranged(1.0, ge=0.0, le=1e6, unit="s^2/rad^2")
    r_delta: float = ranged(30.0, ge=1e-6, le=1e6, unit="1/rad^2")
    feedforward: bool = True
    feedforward_lead_s: float = ranged(0.08, ge=0.0, le=1.0, unit="s")
    rate_anticipation: bool = True
    actuator_lag_s: float = ranged(0.03, ge=0.0, le=1.0, unit="s")
    min_speed_mps: float = ranged(1.0, ge=0.5, le=80.0, unit="m/s")
    max_speed_mps: float = ranged(45.0, gt="min_speed_mps", le=80.0, unit="m/s")
    n_speeds: int = ranged(60, ge=2, le=100, integer=True)

    def __post_init__(self) -> None:
        validate(self)


LQR_PRESETS: dict[str, LQRConfig] = {"default": LQRConfig()}


def lqr_gain(design: DesignModel, v_x: float, config: LQRConfig, sample_time_s: float) -> np.ndarray:
    """Discrete LQR gain K (4,) at speed ``v_x`` [m/s] for the ZOH error model at ``sample_time_s`` [s]."""
    from scipy.linalg import solve_discrete_are

    mdl = error_model(design, v_x)
    ad, bd = zoh(mdl.a, mdl.b, sample_time_s)
    bd = bd.reshape(4, 1)
    q = np.diag([config.q_e_y, config.q_e_y_dot, config.q_e_phi, config.q_e_phi_dot])
    r = np.array([[config.r_delta]])
    p = solve_discrete_are(ad, bd, q, r)
    return np.linalg.solve(r + bd.T @ p @ bd, bd.T @ p @ ad)[0]


@functools.lru_cache(maxsize=32)
def lqr_table(design: DesignModel, config: LQRConfig, sample_time_s: float) -> tuple[np.ndarray, np.ndarray]:
    """``(speeds (S,), rows (S, 5))``: rows = (-K, feedforward gain on kappa [m]) on the speed grid."""
    speeds = np.geomspace(config.min_speed_mps, config.max_speed_mps, config.n_speeds)
    l, kus = design.wheelbase_m, understeer_gradient(design)
    rows = []
    for v in speeds:
        k = lqr_gain(design, float(v), config, sample_time_s)
        ff = (l + kus * v * v - k[2] * sideslip_gain(design, float(v))) if config.feedforward else 0.0
        rows.append(np.concatenate((-k, [ff])))
    table = np.array(rows)
    table.setflags(write=False)
    return speeds, table


class LQR(Policy):
    """Speed-scheduled discrete LQR + curvature feedforward; stateless. See the module docstring."""

    name: ClassVar[str] = "lqr"
    PRESETS: ClassVar[dict[str, LQRConfig]] = LQR_PRESETS
    config_type: ClassVar[type] = LQRConfig
    state_size = 0

    def __init__(self, design: DesignModel, config: LQRConfig | None = None, layout: ObservationLayout = OBS,
                 control_period_s: float = 0.01) -> None:
        super().__init__(design, config, layout, control_period_s)
        cfg: LQRConfig = self.config
        speeds, table = lqr_table(design, cfg, self.control_period_s)
        self.schedule = SpeedSchedule(speeds, table)
        idx = np.array([layout.index(n) for n in ("v_x", "e_y", "e_y_dot", "e_phi", "e_phi_dot", "curvature")])
        self.law = LQRLaw(idx, layout.preview.start, layout.n_preview, float(layout.preview_min_speed_mps),
                          float(layout.preview_dt_s), float(cfg.feedforward_lead_s), self.schedule.speeds,
                          self.schedule.table, self.schedule.slopes,
                          ANTICIPATION_RATE_FACTOR * design.max_road_wheel_rate_radps if cfg.rate_anticipation
                          else 0.0, float(cfg.actuator_lag_s), float(design.wheelbase_m),
                          float(understeer_gradient(design)))

    def _act_batch(self, obs: np.ndarray, state: None) -> tuple[np.ndarray, None]:
        delta = np.empty(obs.shape[0])
        lqr_rows(self.law, obs, delta)
        return delta, None


class LQRLaw(NamedTuple):
    """Parameters of the scheduled LQR law (``lqr_row``)."""

    idx: np.ndarray     # int64 (6,): v_x, e_y, e_y_dot, e_phi, e_phi_dot, curvature
    pv0: int            # first preview entry of the observation
    n_preview: int
    pv_vmin: float      # preview spacing speed floor [m/s]
    pv_dt: float        # preview spacing [s]
    lead_s: float       # feedforward look-ahead [s]
    speeds: np.ndarray  # (S,) [m/s]
    table: np.ndarray   # (S, 5) gains on (e_y, e_y_dot, e_phi, e_phi_dot, kappa)
    slopes: np.ndarray  # (S - 1, 5)
    ant_rate: float     # anticipation rate [rad/s] (0: off)
    ant_lag: float      # actuator lag allowed for by the anticipation [s]
    wheelbase_m: float
    kus: float          # understeer gradient [rad s^2/m]


@kernel
def lqr_row(law: LQRLaw, obs: np.ndarray, i: int, z: np.ndarray) -> float:
    """Road-wheel angle [rad] of observation row ``i`` (``z`` (5,) scratch)."""
    idx = law.idx
    v = float(obs[i, idx[0]])
    kappa = float(obs[i, idx[5]])
    if law.lead_s > 0.0:
        pos = law.lead_s * max(v, 0.0) / (max(v, law.pv_vmin) * law.pv_dt)
        j = min(int(pos), law.n_preview - 1)
        t = min(pos - j, 1.0)
        k0 = kappa if j == 0 else float(obs[i, law.pv0 + j - 1])
        kappa = k0 + t * (float(obs[i, law.pv0 + j]) - k0)
    for c in range(4):
        z[c] = obs[i, idx[1 + c]]
    z[4] = kappa
    delta = schedule_dot(law.speeds, law.table, law.slopes, v, z)
    if law.ant_rate > 0.0:
        delta += rate_anticipation(obs, i, idx[5], law.pv0, law.n_preview, law.pv_vmin, law.pv_dt, v,
                                   law.wheelbase_m + law.kus * v * v, law.ant_rate, law.ant_lag)
    return delta


@kernel
def lqr_rows(law: LQRLaw, obs: np.ndarray, delta: np.ndarray) -> None:
    """``lqr_row`` of every row of ``obs`` into ``delta`` [rad]."""
    z = np.empty(5)
    for i in range(obs.shape[0]):
        delta[i] = lqr_row(law, obs, i, z)
