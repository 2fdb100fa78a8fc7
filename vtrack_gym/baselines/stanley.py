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

Stateless; output clipped to +-max_road_wheel_angle_rad.

Default: k = 2 1/s, k_soft = 1 m/s, k_h = 1, k_r = 0.03 s. Linear closed loop: max|e_y| 2.6 mm (11.11 m/s,
R 100), 18 mm (33.33 m/s, R 500), 63 mm (DLC proxy). Yaw damping costs tracking in the linear model (it fights
the yaw-rate lag at curve entry: k_r = 0 gives 1.0 / 11 / 40 mm) but without it the nonlinear env's 0.8 g
double lane change (DLC120-v0, seed 0) spins out for k = 1..3; with k_r = 0.03 it completes (max|e_y| 0.40 m;
LateralTracking-v0 0.08 m).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from vtrack_gym.baselines.base import Policy, require_range
from vtrack_gym.baselines.linear_models import understeer_gradient
from vtrack_gym.envs.observation import OBS, ObservationLayout
from vtrack_gym.vehicle.params import DesignModel


@dataclass(frozen=True)
class StanleyConfig:
    """Stanley gains.

    gain_k: cross-track gain k [1/s], in (0, 50]. softening_mps: k_soft [m/s], in (0, 50].
    heading_gain: k_h [-], in [0, 5]. yaw_damping_s: k_r [s], in [0, 2].
    feedforward: steady-state steer and sideslip compensation.
    """

    gain_k: float = 2.0
    softening_mps: float = 1.0
    heading_gain: float = 1.0
    yaw_damping_s: float = 0.03
    feedforward: bool = True

    def __post_init__(self) -> None:
        require_range(self, "gain_k", 0.0, 50.0, low_inclusive=False)
        require_range(self, "softening_mps", 0.0, 50.0, low_inclusive=False)
        require_range(self, "heading_gain", 0.0, 5.0)
        require_range(self, "yaw_damping_s", 0.0, 2.0)
        if not isinstance(self.feedforward, bool):
            raise ValueError(f"StanleyConfig.feedforward must be a bool (got {self.feedforward!r})")


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
        self._k = (a1, ff * l, ff * understeer_gradient(design), ff * a2, ff * m * a1 / (cr * l))
        L = layout
        self._idx = (L.index("v_x"), L.index("e_y"), L.index("e_phi"), L.index("yaw_rate"),
                     L.index("yaw_rate_ref"), L.index("curvature"))

    def _act_batch(self, obs: np.ndarray, state: None) -> tuple[np.ndarray, None]:
        iv, iey, iep, ir, irr, ik = self._idx
        a1, l, kus, b0, b2 = self._k
        cfg: StanleyConfig = self.config
        v = np.maximum(obs[:, iv], 0.0)
        kappa = obs[:, ik]
        ep_rel = obs[:, iep] + kappa * (b0 - b2 * v * v)
        e_f = obs[:, iey] + a1 * np.sin(ep_rel)
        delta = (kappa * (l + kus * v * v) - cfg.heading_gain * ep_rel
                 - np.arctan(cfg.gain_k * e_f / (cfg.softening_mps + v))
                 - cfg.yaw_damping_s * (obs[:, ir] - obs[:, irr]))
        return delta, None
