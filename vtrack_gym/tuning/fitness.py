"""The GA fitness: its penalty weights (``FitnessConfig``) and the per-individual results of a rollout.

Fitness (paper-math 8): ``J = ITAE + a_y_penalty * max(0, max|a_y| - 8.83) + wheel_lift_penalty [min F_z <= 0]
+ (incomplete_penalty + incomplete_penalty_per_m * remaining distance) [not completed] + comfort_weight * a_v``
(ISO 2631-1 comfort a_v, off by default). ITAE = int t |e_y| dt by the trapezoid rule over the env's steps,
identical to ``vtrack_gym.evaluation.scoring.metrics.itae`` on a trace. On each ``also_complete`` scenario a run that
does not complete pays the incomplete-run penalty, and max|e_y| above ``also_max_e_y_m`` pays
``also_e_y_penalty_per_m`` per metre (``also_complete_penalty``).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from vtrack_gym.evaluation.scoring.metrics import A_Y_LIMIT_MPS2


@dataclass(frozen=True)
class FitnessConfig:
    """Penalty weights of the GA fitness (see the module docstring); units: the ITAE's m s^2."""

    a_y_limit_mps2: float = A_Y_LIMIT_MPS2
    a_y_penalty_per_mps2: float = 1e4
    wheel_lift_penalty: float = 1e5
    incomplete_penalty: float = 1e5
    incomplete_penalty_per_m: float = 1e3
    comfort_weight: float = 0.0
    also_max_e_y_m: float = 0.25              # allowed max|e_y| [m] on the also_complete scenarios
    also_e_y_penalty_per_m: float = 1e4       # per m of max|e_y| above it

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
                    or value < 0:
                raise ValueError(f"FitnessConfig.{f.name} must be a finite number >= 0 (got {value!r})")


@dataclass
class PopulationResult:
    """Per-individual results of one batched rollout (arrays of shape (P,))."""

    fitness: np.ndarray
    itae: np.ndarray
    completed: np.ndarray
    termination: np.ndarray       # kernel termination code (0: truncated at the time limit)
    remaining_m: np.ndarray
    max_abs_a_y_mps2: np.ndarray
    min_fz_n: np.ndarray
    duration_s: np.ndarray
    comfort_a_v_mps2: np.ndarray
    max_abs_e_y_m: np.ndarray
    steps: int                    # batch steps (= longest episode)
    wall_s: float
    also_completed: dict[str, np.ndarray] = dataclasses.field(default_factory=dict)  # per constraint scenario
    also_max_abs_e_y_m: dict[str, np.ndarray] = dataclasses.field(default_factory=dict)  # per constraint scenario

    def row(self, i: int) -> dict[str, float]:
        """Metrics of individual ``i`` (NaN entries, e.g. an unused comfort term, left out)."""
        out = {"fitness": float(self.fitness[i]), "itae": float(self.itae[i]),
                "completed": float(self.completed[i]), "remaining_m": float(self.remaining_m[i]),
                "max_abs_a_y_mps2": float(self.max_abs_a_y_mps2[i]), "min_fz_n": float(self.min_fz_n[i]),
                "duration_s": float(self.duration_s[i]), "comfort_a_v_mps2": float(self.comfort_a_v_mps2[i]),
                "max_abs_e_y_m": float(self.max_abs_e_y_m[i])}
        for scenario, done in self.also_completed.items():
            out[f"completed_{scenario}"] = float(done[i])
            out[f"max_abs_e_y_m_{scenario}"] = float(self.also_max_abs_e_y_m[scenario][i])
        return {k: v for k, v in out.items() if math.isfinite(v)}


def fitness(fc: FitnessConfig, itae: np.ndarray, max_ay: np.ndarray, min_fz: np.ndarray, completed: np.ndarray,
            remaining_m: np.ndarray, a_v: np.ndarray | None) -> np.ndarray:
    """J of every individual (non-finite values replaced by 1e12); ``a_v`` None when comfort is not scored."""
    j = (itae + fc.a_y_penalty_per_mps2 * np.maximum(max_ay - fc.a_y_limit_mps2, 0.0)
         + fc.wheel_lift_penalty * (min_fz <= 0.0)
         + np.where(completed, 0.0, fc.incomplete_penalty + fc.incomplete_penalty_per_m * remaining_m))
    if a_v is not None:
        j = j + fc.comfort_weight * np.nan_to_num(a_v, nan=0.0)
    return np.where(np.isfinite(j), j, 1e12)


def also_complete_penalty(fc: FitnessConfig, extra: PopulationResult) -> np.ndarray:
    """Penalty per individual from its run on an ``also_complete`` scenario."""
    return np.where(extra.completed, 0.0, fc.incomplete_penalty + fc.incomplete_penalty_per_m * extra.remaining_m) \
        + fc.also_e_y_penalty_per_m * np.maximum(extra.max_abs_e_y_m - fc.also_max_e_y_m, 0.0)
