"""Frozen configs and presets of the paper's SMC and MPC (their own module, so that the preset-file loader
``preset_files`` and the controllers ``smc`` / ``mpc`` import them without importing each other).

Field meanings and the presets are described in ``vtrack_gym.baselines.smc`` and ``vtrack_gym.baselines.mpc``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from vtrack_gym.baselines.base import require_choice, require_int, require_range

PAPER_POLE_RADPS = 0.0445
"""Table 3 "P": the triple pole of the surface dynamics [rad/s]."""
PAPER_REACHING_GAIN = 973.4083
"""Table 3 "H": eta [rad/s^2]."""
PAPER_BOUNDARY_LAYER = 0.6124
"""Table 3 Delta [rad/s]."""


@dataclass(frozen=True)
class SMCConfig:
    """Sliding-mode controller parameters.

    pole_radps: p, the triple pole of the sliding dynamics [rad/s], in (0, 100].
    reaching_gain: eta [rad/s^2] (sigma' = -eta sat(sigma/Delta)), in (0, 1e5].
    boundary_layer: Delta [rad/s], in (0, 1e3].
    sideslip_shift: OPTION 2 (steady-state sideslip shift of the surface).
    limit_layer_rate: widen Delta so that eta/Delta <= 1/T_c (OPTION 4 rule).
    min_speed_mps: speed clamp of the model [m/s], in [0.5, 20].
    guard_band_mps: half-width of the singular-speed guard [m/s], in [0, 3].
    """

    pole_radps: float = 8.0
    reaching_gain: float = 5.0
    boundary_layer: float = 0.1
    sideslip_shift: bool = True
    limit_layer_rate: bool = True
    min_speed_mps: float = 3.0
    guard_band_mps: float = 0.3

    def __post_init__(self) -> None:
        require_range(self, "pole_radps", 0.0, 100.0, low_inclusive=False)
        require_range(self, "reaching_gain", 0.0, 1e5, low_inclusive=False)
        require_range(self, "boundary_layer", 0.0, 1e3, low_inclusive=False)
        require_range(self, "min_speed_mps", 0.5, 20.0)
        require_range(self, "guard_band_mps", 0.0, 3.0)
        for name in ("sideslip_shift", "limit_layer_rate"):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(f"SMCConfig.{name} must be a bool (got {getattr(self, name)!r})")


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


@dataclass(frozen=True)
class MPCConfig:
    """Paper MPC parameters.

    weights: w1..w12 (>= 0). input_weight: w of W2 = w I (> 0).
    prediction_horizon N_p in [1, 400]; control_horizon N_c in [1, N_p]; sample_time_s T_s in [0.001, 0.2] s.
    interpretation: "augmented_outputs" (B1) or "siso_per_step" (A, needs N_p = len(weights)).
    use_preview: preview psi_ref_ddot from the curvature preview. rate_limit: clip Delta_u to the steering rate.
    min_speed_mps / max_speed_mps / n_speeds: the gain-schedule grid (0.5 <= min < max <= 80 m/s, 2..400 points).
    """

    weights: tuple[float, ...] = PAPER_WEIGHTS
    input_weight: float = 0.1
    prediction_horizon: int = 50
    control_horizon: int = 5
    sample_time_s: float = 0.02
    interpretation: str = "augmented_outputs"
    use_preview: bool = True
    rate_limit: bool = True
    min_speed_mps: float = 1.0
    max_speed_mps: float = 45.0
    n_speeds: int = 60

    def __post_init__(self) -> None:
        if len(self.weights) != 12:
            raise ValueError(f"MPCConfig.weights must have 12 entries (got {len(self.weights)})")
        if any(not (isinstance(w, (int, float)) and math.isfinite(w) and w >= 0.0) for w in self.weights):
            raise ValueError(f"MPCConfig.weights must be finite numbers >= 0 (got {self.weights})")
        object.__setattr__(self, "weights", tuple(float(w) for w in self.weights))
        require_range(self, "input_weight", 0.0, 1e6, low_inclusive=False)
        require_int(self, "prediction_horizon", 1, 400)
        require_int(self, "control_horizon", 1, self.prediction_horizon)
        require_range(self, "sample_time_s", 0.001, 0.2)
        require_choice(self, "interpretation", INTERPRETATIONS)
        if self.interpretation == "siso_per_step" and self.prediction_horizon != len(self.weights):
            raise ValueError("MPCConfig.prediction_horizon must equal len(weights) = 12 for interpretation "
                             f"'siso_per_step' (got {self.prediction_horizon})")
        require_range(self, "min_speed_mps", 0.5, 80.0)
        require_range(self, "max_speed_mps", self.min_speed_mps, 80.0, low_inclusive=False)
        require_int(self, "n_speeds", 2, 400)
        for name in ("use_preview", "rate_limit"):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(f"MPCConfig.{name} must be a bool (got {getattr(self, name)!r})")


MPC_PRESETS: dict[str, MPCConfig] = {
    "paper": MPCConfig(),
    "hand": MPCConfig(input_weight=100.0),
    "paper_siso": MPCConfig(interpretation="siso_per_step", prediction_horizon=12, control_horizon=5),
}
