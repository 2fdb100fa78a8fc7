"""Leaderboard suites: which (env, seed, reset options) episodes a policy is scored on.

``paper``: the paper's two nominal scenarios, one episode each (seed 0).
``robust``: both scenarios under randomised friction, mass, target speed, sensor noise and actuator delay,
drawn deterministically from a fixed list of seeds (the same perturbations for every policy and release).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

ROBUST_SEEDS: tuple[int, ...] = (101, 202, 303, 404, 505)


@dataclass(frozen=True)
class Episode:
    """One scored episode of a suite."""

    env_id: str
    seed: int
    options: dict[str, Any] = field(default_factory=dict)


def robust_options(seed: int, nominal_speed_mps: float) -> dict[str, float]:
    """Perturbations of the ``robust`` suite for one seed (friction 0.6-1.0, mass x0.8-1.25, speed +-10 %,
    sensor noise 0-1 x nominal, actuator delay 0-50 ms)."""
    rng = np.random.default_rng(seed)
    return {
        "friction_mu": round(float(rng.uniform(0.6, 1.0)), 3),
        "mass_scale": round(float(rng.uniform(0.8, 1.25)), 3),
        "target_speed_mps": round(float(nominal_speed_mps * rng.uniform(0.9, 1.1)), 3),
        "sensor_noise": round(float(rng.uniform(0.0, 1.0)), 3),
        "actuator_delay_s": round(float(rng.choice([0.0, 0.01, 0.02, 0.03, 0.05])), 3),
    }


def suite_episodes(name: str, quick: bool = False) -> list[Episode]:
    """The episodes of suite ``name`` (``quick`` keeps one robust seed, for smoke tests)."""
    if name == "paper":
        return [Episode("LateralTracking-v0", 0), Episode("DLC120-v0", 0)]
    if name == "robust":
        seeds = ROBUST_SEEDS[:1] if quick else ROBUST_SEEDS
        return ([Episode("LateralTracking-v0", s, robust_options(s, 40 / 3.6)) for s in seeds]
                + [Episode("DLC120-v0", s, robust_options(s, 120 / 3.6)) for s in seeds])
    raise ValueError(f"unknown suite {name!r}; valid: {', '.join(SUITES)}")


SUITES: tuple[str, ...] = ("paper", "robust")
