"""The paper's decoupled sliding-mode steering controller (paper-math section 5, typo fixes applied).

Model (5.1-5.3, constant speed v [m/s]): with lambda = I_z/(m a1) [m] the change of variables (23)
``x1 = e_y - lambda e_phi`` [m], ``x2 = e_y_dot - lambda e_phi_dot`` [m/s], ``x3 = e_phi`` [rad],
``x4 = e_phi_dot`` [rad/s] removes delta from x2' (24, with the FIX phi_dot -> phi_dot_r in x4').
Coefficients (25), (29), (39) (``smc_coefficients``)::

    f3 = (a2 C_ar l - m a1 v^2)/(m a1 v),  f4 = -C_ar l/(m a1 v),  G = v + f3 + lambda f4
    c1 = p^3/(v f4),  c2 = (3p^2 + c1 G + 3p f4 + f4^2)/(f4 (v - G)),  c3 = -3p - f4 - c2 G
    f5 = K_r - c2 f3,  f6 = -h/(I_z v) - c2 f4,  K_r = -(a1^2 C_af + a2^2 C_ar)/(I_z v),  h = a1 C_af - a2 C_ar

Surface (27) ``sigma = x4 - c1 x1 - c2 x2 - c3 x3`` [rad/s] and control law (31)::

    delta = I_z/(a1 C_af) [ -eta sat(sigma/Delta) + psi_ref_ddot (1 + c2 lambda) - f5 r - f6 v_y
                            + c1 x2 + c2 v x4 + c3 x4 ]

which gives ``sigma' = -eta sat(sigma/Delta)`` in the linear model. ``r`` and ``v_y`` are the measured yaw rate
and lateral speed (in (31) they appear as ``x4 + phi_dot_r`` and ``x2 - v x3 + lambda x4``, identical in the
linear model). Signals from the observation: e_y, e_phi, e_y_dot, e_phi_dot, v_y, yaw_rate,
yaw_rate_ref = phi_dot_r [rad/s], yaw_acc_ref = phi_ddot_r [rad/s^2], v_x.

Implementation rules (documented deviations from a literal reading):

* Speed clamp: ``v = max(v_x, min_speed_mps)`` with default 3 m/s. The model is singular at v -> 0 and its
  fastest pole, |K_r| = 249.6/v s^-1, must stay below ~1/T_c for the 10 ms sampled law: v >= 2.5 m/s; the env's
  plant is purely kinematic below 3 m/s anyway (``LowSpeedParams``).
* Singular speed guard (5.6.1, 5.7): the pole placement is singular at
  ``v*^2 = C_ar l (m a1 a2 - I_z)/(m a1)^2`` (10.807 m/s for the paper's car). If ``|v - v*| < guard_band_mps``
  (0.3 m/s) the coefficients and the law are evaluated at ``v* -+ 0.3`` on the side of the current speed
  (logged at DEBUG level, once per call that hits the band).
* Boundary layer vs control period (5.6.3, OPTION 4): a sampled law is only well damped inside the layer if
  ``eta/Delta <= 1/T_c``. With ``limit_layer_rate`` (default True) the effective layer is
  ``Delta_eff = max(Delta, eta T_c)`` (eta kept, Delta widened); a WARNING is logged when this changes the
  configured value (the ``paper`` preset at T_c = 10 ms: Delta 0.6124 -> 9.734).
* Low-speed floor of the yaw dynamics (``low_speed_floor``, default on): the law cancels the yaw mode
  |K_r| = (a1^2 C_af + a2^2 C_ar)/(I_z v) [1/s], which at low speed is faster than the loop's delay allows
  (half a control period plus the actuator lag, ``actuator_lag_s`` = 0.03 s): below ``smc_dynamics_floor``
  (8.74 m/s for the paper's car at T_c = 10 ms; never above v* - guard_band_mps, so that the floor stays on the
  slow side of the singular speed) c1, c2, c3, f5, f6 are evaluated at the floor, the sideslip
  shift at the true speed, and the feedforward ``k7 [(f5(floor) - f5(v)) phi_dot_r + (f6(floor) - f6(v))
  v_y,ss]`` (v_y,ss = phi_dot_r (a2 - m a1 v^2/(C_ar l)), the steady-state lateral speed) keeps the linear
  steady state on a curve exact (e_y,ss = 0). Without it the law limit-cycles through 6-8 m hairpins at 5-7 m/s
  (full lock to half lock every ~1.3 s against the 0.87 rad/s rate limit). Paper scenarios: DLC120-v0 is never
  below the floor; LateralTracking-v0 passes it only while accelerating from rest on the start straight (ITAE
  26.168126467958572 -> 26.1681264679586, max|e_y| and RMS identical to the last bit).
* Rate-limit anticipation (``rate_anticipation``, default on): the reference yaw rate phi_dot_r (and so
  e_phi_dot) is shifted by v dkappa, dkappa = ``laws.rate_anticipation`` / (l + K_us v^2), the curvature of the
  steer planned ahead of a curvature change the rate-limited actuator cannot follow in time; exactly 0 on both
  paper scenarios.
* Steering saturation: the road-wheel angle is clipped to +-max_road_wheel_angle_rad (the action's [-1, 1]).
  The switching term alone is I_z eta/(a1 C_af) = 11.45 rad for the paper's eta.
* OPTION 2 (``sideslip_shift``): surface shifted by the steady-state sideslip,
  ``sigma = x4 - c1 (x1 - x1s) - c2 x2 - c3 (x3 - x3s)``, x3s = f3 phi_dot_r/(v f4), x1s = -lambda x3s, and
  ``-(c3 - c1 lambda) x3s'`` (x3s' = f3 phi_ddot_r/(v f4)) added inside the bracket: e_y,ss = 0 on a curve.

Presets:

* ``paper``: Table 3, p = 0.0445 rad/s, eta = 973.4083 rad/s^2, Delta = 0.6124 rad/s, no shift. It does NOT
  track a geometric path (paper-math 5.6): c1 = -6.2e-7 (no e_y feedback), the surface dynamics are a triple
  pole at -0.0445 s^-1 driven by the unmatched curvature term, and the steady state on a curve is
  ``e_y,ss = e_phi,ss (lambda - c3/c1)`` = -3.9e6 m at 11.11 m/s on R = 100 m. In the linear model (10 ms
  control, steering clipped to 0.6 rad) a 0.5 m offset on a straight decays with a time constant of ~22 s and
  e_y on R = 100 m reaches metres within seconds (see tests/test_smc.py). Kept for faithfulness only.
* ``default`` / ``tuned``: the packaged GA result ``vtrack_gym/baselines/presets/smc_tuned.json`` (the ``hand``
  fields with p, eta, Delta tuned on Case 1 by ``vtrack tune``; its provenance records the command).
* ``accel``: the ``default`` config with high-speed gains, ``high_speed_mps`` v_s = 13 m/s and
  ``pole_speed_exponent`` a = 0.375 (``configs.ACCEL_HIGH_SPEED_MPS``, ``ACCEL_POLE_SPEED_EXPONENT``): above v_s the
  law uses eta v_s / v and p (v_s / v)^a (at 120 km/h eta 2.65 instead of 6.79 rad/s^2, p 7.92 instead of 11.28
  rad/s), below it the ``default`` law to the last bit. ``make_policy("smc", env)`` builds it for an env in a
  longitudinal control mode (``preset_for_control``). The ``default`` preset completes DLC120-v0 only in a narrow
  window of speeds (2 of 17 held set speeds from 31 to 35 m/s in steer and in steer_accel, spinning out at 120 km/h
  in steer_accel) in a limit cycle the steering rate limit feeds; ``accel`` completes every one in steer,
  steer_accel and steer_rate_accel (benchmarks/smc_held_speed.py), LateralTracking-v0 (40 km/h) unchanged. From
  the same sweep (18 speeds per mode, the id's own included): eta scaled alone (a = 0) fails 10 of 18 in
  steer_rate_accel; a = 0.25 and 0.375 with v_s 11.5, 13, 15 or 17 m/s and a = 0.5 with 13 m/s complete all 54;
  a = 0.75 or 1 fail some; v_s = 9 m/s reaches LateralTracking-v0's speed (max|e_y| 0.0145 m against 0.0100).
* ``observer``: the ``default`` config with ``observer=True``: the law runs on a Kalman filter's estimates of
  e_y, e_phi, v_y, r and the road-wheel angle (``vtrack_gym.baselines.observer``; R from the env's declared
  sensor noise). Any preset takes ``observer=True`` as an override.
* ``hand``: p = 8 rad/s with OPTION 2 (sideslip shift), eta = 5 rad/s^2, Delta = 0.1 rad/s (eta/Delta = 50
  s^-1 = half the 10 ms ZOH limit, margin for the env's 30 ms steering lag; switching authority
  I_z eta/(a1 C_af) = 0.059 rad). Linear closed loop (tests/linear_closed_loop.py, 10 ms ZOH, ideal actuator):
  max|e_y| 0.5 mm (11.11 m/s, R 100), 4.8 mm (33.33 m/s, R 500), 16.5 mm (DLC proxy, peak delta 0.133 rad),
  e_y,ss = 0. Chosen among p in {1..10}, eta in {2..20}, Delta in {0.05..1} on the nonlinear env
  (DLC120-v0 seed 0: completed, max|e_y| 0.24 m; LateralTracking-v0: 0.011 m); p = 5, eta = 10, Delta = 0.2
  tracked as well in the linear model but spun out in the env's 0.8 g double lane change.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from vtrack_gym.baselines.base import Policy
from vtrack_gym.baselines.configs import (  # noqa: F401  (re-exported: the SMC's config and presets)
    ACCEL_HIGH_SPEED_MPS,
    ACCEL_POLE_SPEED_EXPONENT,
    ACCEL_PRESET,
    PAPER_BOUNDARY_LAYER,
    PAPER_POLE_RADPS,
    PAPER_REACHING_GAIN,
    SMC_PRESETS,
    SMCConfig,
)
from vtrack_gym.baselines.laws import (
    guarded_speed,
    smc_coefficient_values,
    smc_design_constants,
    smc_dynamics_floor,
    smc_law,
    smc_layer,
    smc_rows,
)
from vtrack_gym.baselines.laws import smc_singular_speed as singular_speed
from vtrack_gym.baselines.observer import ObserverOption
from vtrack_gym.baselines.preset_files import TunedPresets, observer_preset
from vtrack_gym.envs.observation import OBS, ObservationLayout
from vtrack_gym.vehicle.params import DesignModel

logger = logging.getLogger(__name__)

@dataclass(frozen=True)
class SMCCoefficients:
    """Coefficients of paper-math 5.3-5.5 at one speed (lam [m]; the rest in the units of their equations)."""

    lam: float
    f3: float
    f4: float
    G: float  # the paper's symbol (N815 not enabled)
    c1: float
    c2: float
    c3: float
    f5: float
    f6: float


def smc_coefficients(design: DesignModel, v: float, p: float) -> SMCCoefficients:
    """Exact coefficients at speed ``v`` [m/s] (> 0, no clamp, no guard) for pole ``p`` [rad/s]."""
    if not (v > 0.0 and math.isfinite(v)):
        raise ValueError(f"v must be a finite speed > 0 m/s (got {v})")
    values = smc_coefficient_values(smc_design_constants(design), float(v), float(p))
    return SMCCoefficients(*(float(c) for c in values))


class SMC(ObserverOption, TunedPresets, Policy):
    """Decoupled SMC steering (paper-math 5); stateless. See the module docstring for the law and presets.

    The law itself is ``vtrack_gym.baselines.laws.smc_row`` (compiled); ``self.law`` holds its parameters.
    """

    name: ClassVar[str] = "smc"
    PRESETS: ClassVar[dict[str, SMCConfig]] = SMC_PRESETS
    config_type: ClassVar[type] = SMCConfig
    state_size = 0
    FILE_PRESETS: ClassVar[tuple[str, ...]] = ("default", "tuned", "observer", ACCEL_PRESET)

    def __init__(self, design: DesignModel, config: SMCConfig | None = None, layout: ObservationLayout = OBS,
                 control_period_s: float = 0.01, rows: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
                 noise_std: tuple[float, ...] | None = None) -> None:
        """``rows``: (p, eta, Delta) arrays (R,) used instead of the config's, row i for observation row i (the
        GA's populations); the limit_layer_rate rule is then applied per row, silently. ``noise_std``: the env's
        declared sensor noise, the observer's R (``observer.declared_noise_std``)."""
        super().__init__(design, config, layout, control_period_s)
        cfg: SMCConfig = self.config
        self.v_star = singular_speed(design)
        pole, eta, delta = rows if rows is not None else (cfg.pole_radps, cfg.reaching_gain, cfg.boundary_layer)
        pole, eta, delta = (np.asarray(a, dtype=np.float64).reshape(-1) for a in (pole, eta, delta))
        if not (pole.shape == eta.shape == delta.shape) or np.any(pole <= 0) or np.any(eta <= 0) \
                or np.any(delta <= 0):
            raise ValueError("SMC rows: pole, eta, delta must be positive arrays of one shape")
        layer = smc_layer(eta, delta, self.control_period_s, cfg.limit_layer_rate)
        self.law = smc_law(design, layout, pole, eta, layer, cfg.min_speed_mps, cfg.guard_band_mps,
                           cfg.sideslip_shift, cfg.actuator_lag_s if cfg.rate_anticipation else None,
                           smc_dynamics_floor(design, self.control_period_s, cfg.actuator_lag_s,
                                              cfg.guard_band_mps)
                           if cfg.low_speed_floor else 0.0, cfg.high_speed_mps, cfg.pole_speed_exponent)
        self.boundary_layer: float | np.ndarray = layer
        self._attach_observer(noise_std)
        if rows is None:
            self.boundary_layer = float(layer[0])
            if self.boundary_layer != cfg.boundary_layer:
                logger.warning("SMC: eta/Delta = %.1f 1/s exceeds 1/T_c = %.1f 1/s; boundary layer widened from "
                               "%.4g to %.4g rad/s (limit_layer_rate rule, paper-math 5.6.3 / OPTION 4)",
                               cfg.reaching_gain / cfg.boundary_layer, 1.0 / self.control_period_s,
                               cfg.boundary_layer, self.boundary_layer)

    def model_speed(self, v_x: float) -> float:
        """Speed [m/s] the coefficients are evaluated at: clamped to min_speed_mps, then guarded around v*."""
        cfg: SMCConfig = self.config
        v = max(v_x, cfg.min_speed_mps)
        vg = guarded_speed(v, self.v_star, cfg.guard_band_mps)
        if vg != v:
            logger.debug("SMC: speed %.3f m/s within %.2f m/s of v* = %.3f m/s; coefficients at %.3f m/s",
                         v, cfg.guard_band_mps, self.v_star, vg)
        return vg

    def sliding_variable(self, observation: np.ndarray) -> np.ndarray:
        """sigma [rad/s] for a batch (N, obs_dim) or one observation (diagnostics)."""
        obs = np.atleast_2d(np.asarray(observation, dtype=np.float64))
        return self._evaluate(obs)[1]

    def _evaluate(self, obs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(road-wheel angles [rad], sigma [rad/s]) of every row."""
        n = obs.shape[0]
        delta, sigma = np.empty(n), np.empty(n)
        guarded = smc_rows(self.law, obs, delta, sigma)
        if guarded:
            logger.debug("SMC: %d speed(s) within %.2f m/s of v* = %.3f m/s (singular-speed guard)", guarded,
                         self.config.guard_band_mps, self.v_star)
        return delta, sigma

    @classmethod
    def _file_preset(cls, preset: str) -> SMCConfig:
        """``default``/``tuned``: the packaged GA result; ``observer``: the same with the Kalman filter; ``accel``:
        the same with high-speed gains (``ACCEL_HIGH_SPEED_MPS``, ``ACCEL_POLE_SPEED_EXPONENT``)."""
        if preset == ACCEL_PRESET:
            return dataclasses.replace(observer_preset(cls.name, "tuned"), high_speed_mps=ACCEL_HIGH_SPEED_MPS,
                                       pole_speed_exponent=ACCEL_POLE_SPEED_EXPONENT)
        return observer_preset(cls.name, preset)

    @classmethod
    def preset_for_control(cls, preset: str, control: str | None) -> str:
        """``accel`` for the ``default`` preset in a longitudinal control mode (``steer_accel``,
        ``steer_rate_accel``), else ``preset`` (the ``steer`` mode's default is the packaged GA result)."""
        return ACCEL_PRESET if preset == "default" and control not in (None, "steer") else preset

    def _law_batch(self, obs: np.ndarray, state: np.ndarray | None) -> tuple[np.ndarray, None]:
        return self._evaluate(obs)[0], None
