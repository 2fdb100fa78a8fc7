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
* ``hand``: p = 8 rad/s with OPTION 2 (sideslip shift), eta = 5 rad/s^2, Delta = 0.1 rad/s (eta/Delta = 50
  s^-1 = half the 10 ms ZOH limit, margin for the env's 30 ms steering lag; switching authority
  I_z eta/(a1 C_af) = 0.059 rad). Linear closed loop (tests/linear_closed_loop.py, 10 ms ZOH, ideal actuator):
  max|e_y| 0.5 mm (11.11 m/s, R 100), 4.8 mm (33.33 m/s, R 500), 16.5 mm (DLC proxy, peak delta 0.133 rad),
  e_y,ss = 0. Chosen among p in {1..10}, eta in {2..20}, Delta in {0.05..1} on the nonlinear env
  (DLC120-v0 seed 0: completed, max|e_y| 0.24 m; LateralTracking-v0: 0.011 m); p = 5, eta = 10, Delta = 0.2
  tracked as well in the linear model but spun out in the env's 0.8 g double lane change.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from vtrack_gym._ranges import documented, ranged, validate
from vtrack_gym.baselines.base import Policy
from vtrack_gym.envs.observation import OBS, ObservationLayout
from vtrack_gym.vehicle.params import DesignModel

logger = logging.getLogger(__name__)

PAPER_POLE_RADPS = 0.0445
"""Table 3 "P": the triple pole of the surface dynamics [rad/s]."""
PAPER_REACHING_GAIN = 973.4083
"""Table 3 "H": eta [rad/s^2]."""
PAPER_BOUNDARY_LAYER = 0.6124
"""Table 3 Delta [rad/s]."""


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


@documented
@dataclass(frozen=True)
class SMCConfig:
    """Sliding-mode controller parameters.

    pole_radps: p, the triple pole of the sliding dynamics [rad/s].
    reaching_gain: eta [rad/s^2] (sigma' = -eta sat(sigma/Delta)).
    boundary_layer: Delta [rad/s].
    sideslip_shift: OPTION 2 (steady-state sideslip shift of the surface).
    limit_layer_rate: widen Delta so that eta/Delta <= 1/T_c (OPTION 4 rule).
    min_speed_mps: speed clamp of the model [m/s].
    guard_band_mps: half-width of the singular-speed guard [m/s].
    """

    pole_radps: float = ranged(8.0, gt=0.0, le=100.0, unit="rad/s")
    reaching_gain: float = ranged(5.0, gt=0.0, le=1e5, unit="rad/s^2")
    boundary_layer: float = ranged(0.1, gt=0.0, le=1e3, unit="rad/s")
    sideslip_shift: bool = True
    limit_layer_rate: bool = True
    min_speed_mps: float = ranged(3.0, ge=0.5, le=20.0, unit="m/s")
    guard_band_mps: float = ranged(0.3, ge=0.0, le=3.0, unit="m/s")

    def __post_init__(self) -> None:
        validate(self)


SMC_PRESETS: dict[str, SMCConfig] = {
    "paper": SMCConfig(pole_radps=PAPER_POLE_RADPS, reaching_gain=PAPER_REACHING_GAIN,
                       boundary_layer=PAPER_BOUNDARY_LAYER, sideslip_shift=False),
    "hand": SMCConfig(),
}


def singular_speed(design: DesignModel) -> float:
    """v* = sqrt(C_ar l (m a1 a2 - I_z)) / (m a1) [m/s] (10.807 for the paper's car); NaN if m a1 a2 <= I_z."""
    m, iz, a1, a2 = design.mass_kg, design.yaw_inertia_kgm2, design.cg_to_front_axle_m, design.cg_to_rear_axle_m
    arg = design.rear_cornering_stiffness_npr * design.wheelbase_m * (m * a1 * a2 - iz)
    return math.sqrt(arg) / (m * a1) if arg > 0.0 else math.nan


def guarded_speed(v: float, v_star: float, band: float = 0.3) -> float:
    """``v`` [m/s], or ``v* -+ band`` on the side of ``v`` if ``|v - v*| < band`` (paper-math 5.7 guard)."""
    if band > 0.0 and abs(v - v_star) < band:
        return v_star - band if v < v_star else v_star + band
    return v


def _design_constants(design: DesignModel) -> tuple[float, ...]:
    """(m a1, a2 C_ar l, C_ar l, lambda, I_z, a1^2 C_af + a2^2 C_ar, h, I_z/(a1 C_af))."""
    m, iz, a1, a2 = design.mass_kg, design.yaw_inertia_kgm2, design.cg_to_front_axle_m, design.cg_to_rear_axle_m
    cf, cr, l = design.front_cornering_stiffness_npr, design.rear_cornering_stiffness_npr, design.wheelbase_m
    return (m * a1, a2 * cr * l, cr * l, iz / (m * a1), iz, a1 * a1 * cf + a2 * a2 * cr, a1 * cf - a2 * cr,
            iz / (a1 * cf))


def _coefficients(k: tuple[float, ...], v: Any, p: float) -> tuple[Any, ...]:
    """(lam, f3, f4, G, c1, c2, c3, f5, f6); ``v`` a float or an array (same arithmetic for both paths)."""
    ma1, a2crl, crl, lam, iz, yaw_c, h, _ = k
    f3 = (a2crl - ma1 * v * v) / (ma1 * v)
    f4 = -crl / (ma1 * v)
    g = v + f3 + lam * f4
    c1 = p * p * p / (v * f4)
    c2 = (3.0 * p * p + c1 * g + 3.0 * p * f4 + f4 * f4) / (f4 * (v - g))
    c3 = -3.0 * p - f4 - c2 * g
    f5 = -yaw_c / (iz * v) - c2 * f3
    f6 = -h / (iz * v) - c2 * f4
    return lam, f3, f4, g, c1, c2, c3, f5, f6


def smc_coefficients(design: DesignModel, v: float, p: float) -> SMCCoefficients:
    """Exact coefficients at speed ``v`` [m/s] (> 0, no clamp, no guard) for pole ``p`` [rad/s]."""
    if not (v > 0.0 and math.isfinite(v)):
        raise ValueError(f"v must be a finite speed > 0 m/s (got {v})")
    return SMCCoefficients(*(float(c) for c in _coefficients(_design_constants(design), float(v), float(p))))


def _law(k: tuple[float, ...], cf: tuple[Any, ...], v: Any, p_shift: bool, e_y: Any, e_phi: Any, e_y_dot: Any,
         e_phi_dot: Any, v_y: Any, r: Any, rate_ref: Any, acc_ref: Any) -> tuple[Any, Any]:
    """``(sigma [rad/s], delta_eq [rad])``: the surface and the law (31) without the switching term."""
    lam, f3, f4, _, c1, c2, c3, f5, f6 = cf
    x1 = e_y - lam * e_phi
    x2 = e_y_dot - lam * e_phi_dot
    bracket = acc_ref * (1.0 + c2 * lam) - f5 * r - f6 * v_y + c1 * x2 + (c2 * v + c3) * e_phi_dot
    if p_shift:
        x3s = f3 * rate_ref / (v * f4)
        x3s_dot = f3 * acc_ref / (v * f4)
        sigma = e_phi_dot - c1 * (x1 + lam * x3s) - c2 * x2 - c3 * (e_phi - x3s)
        bracket = bracket - (c3 - c1 * lam) * x3s_dot
    else:
        sigma = e_phi_dot - c1 * x1 - c2 * x2 - c3 * e_phi
    return sigma, k[7] * bracket


class SMC(Policy):
    """Decoupled SMC steering (paper-math 5); stateless. See the module docstring for the law and presets."""

    name: ClassVar[str] = "smc"
    PRESETS: ClassVar[dict[str, SMCConfig]] = SMC_PRESETS
    FILE_PRESETS: ClassVar[tuple[str, ...]] = ("default", "tuned")
    config_type: ClassVar[type] = SMCConfig
    state_size = 0

    @classmethod
    def _file_preset(cls, preset: str) -> SMCConfig:
        from vtrack_gym.baselines.preset_files import tuned_config

        return tuned_config(cls.name)

    def __init__(self, design: DesignModel, config: SMCConfig | None = None, layout: ObservationLayout = OBS,
                 control_period_s: float = 0.01) -> None:
        super().__init__(design, config, layout, control_period_s)
        cfg: SMCConfig = self.config
        self._k = _design_constants(design)
        self.v_star = singular_speed(design)
        self.boundary_layer = cfg.boundary_layer
        if cfg.limit_layer_rate and cfg.reaching_gain * self.control_period_s > cfg.boundary_layer:
            self.boundary_layer = cfg.reaching_gain * self.control_period_s
            logger.warning("SMC: eta/Delta = %.1f 1/s exceeds 1/T_c = %.1f 1/s; boundary layer widened from %.4g "
                           "to %.4g rad/s (limit_layer_rate rule, paper-math 5.6.3 / OPTION 4)",
                           cfg.reaching_gain / cfg.boundary_layer, 1.0 / self.control_period_s,
                           cfg.boundary_layer, self.boundary_layer)
        self._eta_k = cfg.reaching_gain * self._k[7]
        self._inv_layer = 1.0 / self.boundary_layer
        self._idx = tuple(layout.index(n) for n in ("v_x", "e_y", "e_phi", "e_y_dot", "e_phi_dot", "v_y",
                                                    "yaw_rate", "yaw_rate_ref", "yaw_acc_ref"))

    def model_speed(self, v_x: float) -> float:
        """Speed [m/s] the coefficients are evaluated at: clamped to min_speed_mps, then guarded around v*."""
        cfg: SMCConfig = self.config
        v = max(v_x, cfg.min_speed_mps)
        if math.isnan(self.v_star):
            return v
        vg = guarded_speed(v, self.v_star, cfg.guard_band_mps)
        if vg != v:
            logger.debug("SMC: speed %.3f m/s within %.2f m/s of v* = %.3f m/s; coefficients at %.3f m/s",
                         v, cfg.guard_band_mps, self.v_star, vg)
        return vg

    def sliding_variable(self, observation: np.ndarray) -> np.ndarray:
        """sigma [rad/s] for a batch (N, obs_dim) or one observation (diagnostics)."""
        obs = np.atleast_2d(np.asarray(observation, dtype=np.float64))
        sigma, _ = self._evaluate(obs)
        return sigma

    def _evaluate(self, obs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        iv, iey, iep, ieyd, iepd, ivy, ir, irr, iar = self._idx
        cfg: SMCConfig = self.config
        v = np.maximum(obs[:, iv], cfg.min_speed_mps)
        if not math.isnan(self.v_star) and cfg.guard_band_mps > 0.0:
            near = np.abs(v - self.v_star) < cfg.guard_band_mps
            if near.any():
                logger.debug("SMC: %d speed(s) within the singular-speed guard band", int(near.sum()))
                side = np.where(v < self.v_star, -cfg.guard_band_mps, cfg.guard_band_mps)
                v = np.where(near, self.v_star + side, v)
        cf = _coefficients(self._k, v, cfg.pole_radps)
        return _law(self._k, cf, v, cfg.sideslip_shift, obs[:, iey], obs[:, iep], obs[:, ieyd], obs[:, iepd],
                    obs[:, ivy], obs[:, ir], obs[:, irr], obs[:, iar])

    def _act_batch(self, obs: np.ndarray, state: np.ndarray | None) -> tuple[np.ndarray, None]:
        sigma, delta_eq = self._evaluate(obs)
        sat = np.clip(sigma * self._inv_layer, -1.0, 1.0)
        return delta_eq - self._eta_k * sat, None

    def _act_single(self, row: list[float], state: list[float] | None) -> tuple[float, None]:
        iv, iey, iep, ieyd, iepd, ivy, ir, irr, iar = self._idx
        v = self.model_speed(row[iv])
        cf = _coefficients(self._k, v, self.config.pole_radps)
        sigma, delta_eq = _law(self._k, cf, v, self.config.sideslip_shift, row[iey], row[iep], row[ieyd],
                               row[iepd], row[ivy], row[ir], row[irr], row[iar])
        z = sigma * self._inv_layer
        sat = 1.0 if z > 1.0 else (-1.0 if z < -1.0 else z)
        return delta_eq - self._eta_k * sat, None
