"""Frozen configs and presets of the paper's SMC and MPC (their own module, so that the preset-file loader
``preset_files`` and the controllers ``smc`` / ``mpc`` import them without importing each other).

Field meanings and the presets are described in ``vtrack_gym.baselines.smc`` and ``vtrack_gym.baselines.mpc``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from vtrack_gym._ranges import documented, ranged, validate
from vtrack_gym.baselines.base import require_choice

PAPER_POLE_RADPS = 0.0445
"""Table 3 "P": the triple pole of the surface dynamics [rad/s]."""
PAPER_REACHING_GAIN = 973.4083
"""Table 3 "H": eta [rad/s^2]."""
PAPER_BOUNDARY_LAYER = 0.6124
"""Table 3 Delta [rad/s]."""


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
    rate_anticipation: track the rate-limit anticipated yaw rate (``laws.rate_anticipation``; exactly inactive
    while the previewed steady-state steer is reachable at the actuator's rate).
    actuator_lag_s: the steering actuator's lag [s] (anticipation and low-speed floor).
    low_speed_floor: evaluate the yaw dynamics no slower than ``smc_dynamics_floor`` (steady state kept).
    observer: run the law on a Kalman filter's state estimates (``vtrack_gym.baselines.observer``).
    high_speed_mps: v_s [m/s]; above it the reaching gain falls as 1/v, eta v_s / v, and the pole as
    p (v_s / v)^pole_speed_exponent (0: constant gains; the ``accel`` preset's 13 m/s).
    pole_speed_exponent: the exponent of the pole's high-speed scaling (the ``accel`` preset's 0.375).
    """

    pole_radps: float = ranged(8.0, gt=0.0, le=100.0, unit="rad/s")
    reaching_gain: float = ranged(5.0, gt=0.0, le=1e5, unit="rad/s^2")
    boundary_layer: float = ranged(0.1, ge=1e-3, le=1e3, unit="rad/s")
    sideslip_shift: bool = True
    limit_layer_rate: bool = True
    min_speed_mps: float = ranged(3.0, ge=0.5, le=20.0, unit="m/s")
    guard_band_mps: float = ranged(0.3, ge=0.05, le=3.0, unit="m/s")  # > 0: no division by zero at v*
    rate_anticipation: bool = True
    actuator_lag_s: float = ranged(0.03, ge=0.0, le=1.0, unit="s")
    low_speed_floor: bool = True
    observer: bool = False
    high_speed_mps: float = ranged(0.0, ge=0.0, le=100.0, unit="m/s")
    pole_speed_exponent: float = ranged(0.0, ge=0.0, le=2.0)

    def __post_init__(self) -> None:
        validate(self)


ACCEL_PRESET = "accel"
"""The SMC preset ``make_policy("smc", env)`` builds for an env in a longitudinal control mode."""
ACCEL_HIGH_SPEED_MPS = 13.0
"""The ``accel`` preset's ``high_speed_mps`` [m/s] (chosen from a DLC120-v0 held-speed sweep, see smc.py)."""
ACCEL_POLE_SPEED_EXPONENT = 0.375
"""The ``accel`` preset's ``pole_speed_exponent`` (chosen from the same sweep)."""


SMC_PRESETS: dict[str, SMCConfig] = {
    "paper": SMCConfig(pole_radps=PAPER_POLE_RADPS, reaching_gain=PAPER_REACHING_GAIN,
                       boundary_layer=PAPER_BOUNDARY_LAYER, sideslip_shift=False),
    "hand": SMCConfig(),
}


PAPER_WEIGHTS: tuple[float, ...] = (0.0015, 0.3626, 0.0152, 0.6179, 0.2788, 0.2453, 0.1527, 0.8068,
                                    0.0012, 0.0207, 0.7908, 0.7904)
"""Table 3 MPC weights w1..w12 (B1: on Delta x_m (8) and y, phi, e_y, e_phi)."""
INTERPRETATIONS = ("augmented_outputs", "siso_per_step")
"""B1 (paper-math 4.1, chosen) and A."""
OUTPUTS = {"augmented_outputs": (0, 2, 4, 6), "siso_per_step": (4,)}
"""Indices in x_m of the outputs y of each interpretation."""
RELATIVE = (0, 2)
"""x_m indices (y, phi) whose output value is zero in the car-fixed frame (relative outputs)."""


@documented
@dataclass(frozen=True)
class MPCConfig:
    """Paper MPC parameters.

    weights: w1..w12 (>= 0). input_weight: w of W2 = w I.
    prediction_horizon N_p; control_horizon N_c; sample_time_s T_s [s].
    interpretation: "augmented_outputs" (B1) or "siso_per_step" (A, needs N_p = len(weights)).
    use_preview: preview psi_ref_ddot from the curvature preview. rate_limit: clip Delta_u to the steering rate.
    min_speed_mps / max_speed_mps / n_speeds: the gain-schedule grid [m/s].
    rate_anticipation: track the rate-limit anticipated reference (``laws.mpc_curvature_shift``; exactly
    inactive while the previewed steady-state steer is reachable at the actuator's rate).
    actuator_lag_s: the steering actuator's lag the anticipation allows for [s].
    front_slip_limit: keep the command within this multiple of mu F_zf / C_f of the front axle's kinematic
    direction (``mpc.front_slip_bound``; 0: no bound): no steer beyond the front tyres' peak slip angle.
    observer: run the law on a Kalman filter's state estimates (``vtrack_gym.baselines.observer``).
    """

    weights: tuple[float, ...] = PAPER_WEIGHTS
    input_weight: float = ranged(0.1, ge=1e-6, le=1e6)
    prediction_horizon: int = ranged(50, ge=1, le=60, integer=True)
    control_horizon: int = ranged(5, ge=1, le="prediction_horizon", integer=True)
    sample_time_s: float = ranged(0.02, ge=0.001, le=0.2, unit="s")
    interpretation: str = "augmented_outputs"
    use_preview: bool = True
    rate_limit: bool = True
    min_speed_mps: float = ranged(1.0, ge=0.5, le=80.0, unit="m/s")
    max_speed_mps: float = ranged(45.0, gt="min_speed_mps", le=80.0, unit="m/s")
    n_speeds: int = ranged(60, ge=2, le=100, integer=True)
    rate_anticipation: bool = True
    actuator_lag_s: float = ranged(0.03, ge=0.0, le=1.0, unit="s")
    front_slip_limit: float = ranged(2.0, ge=0.0, le=10.0)
    observer: bool = False

    def __post_init__(self) -> None:
        validate(self)
        if len(self.weights) != 12:
            raise ValueError(f"MPCConfig.weights must have 12 entries (got {len(self.weights)})")
        if any(not (isinstance(w, (int, float)) and math.isfinite(w) and 0.0 <= w <= 1e6) for w in self.weights):
            raise ValueError(f"MPCConfig.weights must be numbers in [0, 1e6] (got {self.weights})")
        object.__setattr__(self, "weights", tuple(float(w) for w in self.weights))
        require_choice(self, "interpretation", INTERPRETATIONS)
        if self.interpretation == "siso_per_step" and self.prediction_horizon != len(self.weights):
            raise ValueError("MPCConfig.prediction_horizon must equal len(weights) = 12 for interpretation "
                             f"'siso_per_step' (got {self.prediction_horizon})")


MPC_PRESETS: dict[str, MPCConfig] = {   # the paper's presets keep the paper's law (no anticipation, no slip bound)
    "paper": MPCConfig(rate_anticipation=False, front_slip_limit=0.0),
    "hand": MPCConfig(input_weight=100.0),
    "paper_siso": MPCConfig(interpretation="siso_per_step", prediction_horizon=12, control_horizon=5,
                            rate_anticipation=False, front_slip_limit=0.0),
}
