"""Front-axle Stanley steering (Thrun et al. 2006; Hoffmann et al. 2007) for the observation interface (peer).

Law (road-wheel angle [rad], left-positive; e_y left-positive so a car left of the path steers right)::

    delta = delta_ff - k_h (e_phi - e_phi,ss) - atan(k e_f / (k_soft + v)) - k_r (r - psi_ref_dot)
    e_f   = e_y + a1 sin(e_phi - e_phi,ss)            (lateral offset of the front axle [m])
    delta_ff = kappa (l + K_us v^2),  e_phi,ss = -beta_ss = -kappa (C_ar a2 l - m a1 v^2)/(C_ar l)

* Front-axle error: the observation gives the CG's e_y; the front axle sits a1 ahead along the heading, so its
  offset from the path is e_y + a1 sin(e_phi) to first order (a1 from the design model).
* Steady-state sideslip (Hoffmann's psi_ss): on a curve the car needs the heading error e_phi,ss = -beta_ss;
  subtracting it from the heading term and from the front-axle projection makes the steady state on a
  constant curvature e_y = 0 exactly in the linear model (the design-model values of 1.2).
* delta_ff: the steady-state steer (understeer gradient K_us) for the current curvature, as usual for
  dynamic Stanley; ``feedforward=False`` removes it and e_phi,ss.
* Yaw-rate damping ``k_r (r - psi_ref_dot)`` (Hoffmann's ``k_d,yaw``) stabilises the heading at speed.
* v = max(v_x, 0); k_soft keeps the cross-track term finite at standstill.
* Below ``yaw_damping_speed_mps`` (20 m/s) the damping time grows as 1/v: k_r v is held at its value there, so
  the term acts on the curvature error r/v - kappa with a fixed length (0.6 m) instead of fading at low speed,
  where the rate-limited steering overshoots through tight S-bends (DLC120-v0 is driven above it: unchanged).
* Rate-limit anticipation (``rate_anticipation``, default on): ``laws.rate_anticipation`` is added to delta
  (exactly 0 while the previewed steady-state steer is reachable at the actuator's rate, see ``lqr``).

Stateless; output clipped to +-max_road_wheel_angle_rad.

Default: k = 2 1/s, k_soft = 1 m/s, k_h = 1, k_r = 0.03 s (above 20 m/s). Linear closed loop: max|e_y| 2.6 mm
(11.11 m/s, R 100), 18 mm (33.33 m/s, R 500), 63 mm (DLC proxy). Yaw damping costs tracking in the linear model (it
fights the yaw-rate lag at curve entry: k_r = 0 gives 1.0 / 11 / 40 mm) but without it the nonlinear env's 0.8 g
double lane change (DLC120-v0, seed 0) spins out for k = 1..3; with k_r = 0.03 it completes (max|e_y| 0.40 m;
LateralTracking-v0 0.08 m). On the curvature-limited circuits of ``benchmarks/own_tracks.py`` (6 m hairpins,
S-bends) the anticipation and the low-speed damping bring max|e_y| from up to 2.3 m to 0.5 m.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar, NamedTuple

import numpy as np

from vtrack_gym._jit import kernel
from vtrack_gym._ranges import documented, ranged, validate
from vtrack_gym.baselines.base import Policy
from vtrack_gym.baselines.laws import ANTICIPATION_RATE_FACTOR, rate_anticipation
from vtrack_gym.baselines.linear_models import understeer_gradient
from vtrack_gym.envs.observation import OBS, ObservationLayout
from vtrack_gym.vehicle.params import DesignModel


@documented
@dataclass(frozen=True)
class StanleyConfig:
    """Stanley gains.

    gain_k: cross-track gain k [1/s]. softening_mps: k_soft [m/s].
    heading_gain: k_h [-]. yaw_damping_s: k_r [s]; yaw_damping_speed_mps: below it k_r grows as 1/v [m/s]
    (0: constant).
    feedforward: steady-state steer and sideslip compensation.
    rate_anticipation: add the rate-limit anticipation (``laws.rate_anticipation``).
    actuator_lag_s: the steering actuator's lag the anticipation allows for [s].
    """

    gain_k: float = ranged(2.0, gt=0.0, le=50.0, unit="1/s")
    softening_mps: float = ranged(1.0, gt=0.0, le=50.0, unit="m/s")
    heading_gain: float = ranged(1.0, ge=0.0, le=5.0)
    yaw_damping_s: float = ranged(0.03, ge=0.0, le=2.0, unit="s")
    feedforward: bool = True
    rate_anticipation: bool = True
    actuator_lag_s: float = ranged(0.03, ge=0.0, le=1.0, unit="s")
    yaw_damping_speed_mps: float = ranged(20.0, ge=0.0, le=80.0, unit="m/s")

    def __post_init__(self) -> None:
        validate(self)


STANLEY_PRESETS: dict[str, StanleyConfig] = {"default": StanleyConfig()}


class Stanley(Policy):
    """Front-axle Stanley with feedforward, sideslip compensation and yaw damping; stateless."""

    name: ClassVar[str] = "stanley"
    PRESETS: ClassVar[dict[str, StanleyConfig]] = STANLEY_PRESETS
    config_type: ClassVar[type] = StanleyConfig
    state_size = 0

    def __init__(self, design: DesignModel, config: StanleyConfig | None = None, layout: ObservationLayout = OBS,
                 control_period_s: float = 0.01) -> None:
        super().__init__(design, config, layout, control_period_s)
        m, a1, a2 = design.mass_kg, design.cg_to_front_axle_m, design.cg_to_rear_axle_m
        cr, l = design.rear_cornering_stiffness_npr, design.wheelbase_m
        ff = 1.0 if self.config.feedforward else 0.0
        # kappa multipliers: delta_ss = kappa (l + kus v^2); e_phi,ss = -kappa (b0 - b2 v^2)
        cfg: StanleyConfig = self.config
        k = np.array((a1, ff * l, ff * understeer_gradient(design), ff * a2, ff * m * a1 / (cr * l)))
        idx = np.array([layout.index(n) for n in ("v_x", "e_y", "e_phi", "yaw_rate", "yaw_rate_ref", "curvature")])
        self.law = StanleyLaw(idx, k, float(cfg.gain_k), float(cfg.softening_mps), float(cfg.heading_gain),
                              float(cfg.yaw_damping_s), layout.preview.start, layout.n_preview,
                              float(layout.preview_min_speed_mps), float(layout.preview_dt_s),
                              ANTICIPATION_RATE_FACTOR * design.max_road_wheel_rate_radps
                              if cfg.rate_anticipation else 0.0, float(cfg.actuator_lag_s),
                              float(l), float(understeer_gradient(design)), float(cfg.yaw_damping_speed_mps))

    def _act_batch(self, obs: np.ndarray, state: None) -> tuple[np.ndarray, None]:
        delta = np.empty(obs.shape[0])
        stanley_rows(self.law, obs, delta)
        return delta, None


class StanleyLaw(NamedTuple):
    """Parameters of the Stanley law (``stanley_row``)."""

    idx: np.ndarray      # int64 (6,): v_x, e_y, e_phi, yaw_rate, yaw_rate_ref, curvature
    k: np.ndarray        # (5,): a1 [m], l [m], K_us [rad s^2/m], b0 [m], b2 [s^2/m] (feedforward terms, 0 if off)
    gain_k: float        # [1/s]
    softening_mps: float
    heading_gain: float
    yaw_damping_s: float
    pv0: int             # first preview entry of the observation
    n_preview: int
    pv_vmin: float       # preview spacing speed floor [m/s]
    pv_dt: float         # preview spacing [s]
    ant_rate: float      # anticipation rate [rad/s] (0: off)
    ant_lag: float       # actuator lag allowed for by the anticipation [s]
    wheelbase_m: float
    kus: float           # understeer gradient [rad s^2/m]
    damping_speed: float  # below this speed [m/s] the yaw damping grows as 1/v (0: constant)


@kernel
def stanley_row(law: StanleyLaw, obs: np.ndarray, i: int) -> float:
    """Road-wheel angle [rad] of observation row ``i``."""
    idx, k = law.idx, law.k
    v = max(float(obs[i, idx[0]]), 0.0)
    kappa = float(obs[i, idx[5]])
    gain = k[1] + k[2] * v * v
    ep_rel = float(obs[i, idx[2]]) + kappa * (k[3] - k[4] * v * v)
    e_f = float(obs[i, idx[1]]) + k[0] * math.sin(ep_rel)
    delta = (kappa * gain - law.heading_gain * ep_rel
             - math.atan(law.gain_k * e_f / (law.softening_mps + v))
             - law.yaw_damping_s * max(1.0, law.damping_speed / max(v, 1e-3))
             * (float(obs[i, idx[3]]) - float(obs[i, idx[4]])))
    if law.ant_rate > 0.0 and gain > 0.0:  # the steady-state steer planned ahead of the rate limit
        delta += rate_anticipation(obs, i, idx[5], law.pv0, law.n_preview, law.pv_vmin, law.pv_dt, v, gain,
                                   law.ant_rate, law.ant_lag)
    return delta


@kernel
def stanley_rows(law: StanleyLaw, obs: np.ndarray, delta: np.ndarray) -> None:
    """``stanley_row`` of every row of ``obs`` into ``delta`` [rad]."""
    for i in range(obs.shape[0]):
        delta[i] = stanley_row(law, obs, i)
