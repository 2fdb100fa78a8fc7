"""``robust``: both paper scenarios under randomised friction, mass, target speed, sensor noise and actuator delay,
drawn deterministically from a fixed list of seeds (the same perturbations for every policy and release).

The friction range of each scenario keeps the course physically drivable: the handling course's 20 m hairpin needs
~0.63 g at 40 km/h (mu drawn in 0.75-1.0) and the lane change ~0.81 g at 120 km/h (mu drawn in 0.9-1.1); below that
every policy must fail, which would measure the road, not the controller.
"""

from __future__ import annotations

import numpy as np

from vtrack_gym.envs.config import DLC120, LATERAL_TRACKING
from vtrack_gym.evaluation.rollouts.episodes import Episode
from vtrack_gym.evaluation.suite.suite_parts import Suite

ROBUST_SEEDS: tuple[int, ...] = (101, 202, 303, 404, 505)
ROBUST_FRICTION: dict[str, tuple[float, float]] = {"LateralTracking-v0": (0.75, 1.0), "DLC120-v0": (0.9, 1.1)}


def robust_options(seed: int, nominal_speed_mps: float, friction_range: tuple[float, float] = (0.75, 1.0),
                   ) -> dict[str, float]:
    """Perturbations of the ``robust`` suite for one seed (friction in ``friction_range``, mass x0.8-1.25,
    speed +-10 %, sensor noise 0-1 x nominal, actuator delay 0-50 ms)."""
    rng = np.random.default_rng(seed)
    return {
        "friction_mu": round(float(rng.uniform(*friction_range)), 3),
        "mass_scale": round(float(rng.uniform(0.8, 1.25)), 3),
        "target_speed_mps": round(float(nominal_speed_mps * rng.uniform(0.9, 1.1)), 3),
        "sensor_noise": round(float(rng.uniform(0.0, 1.0)), 3),
        "actuator_delay_s": round(float(rng.choice([0.0, 0.01, 0.02, 0.03, 0.05])), 3),
    }


def robust_episodes(seeds: tuple[int, ...]) -> list[Episode]:
    """Each scenario under the perturbations drawn from each seed."""
    return [Episode(sc.name, s, robust_options(s, sc.speed.target_speed_mps, ROBUST_FRICTION[sc.name]))
            for sc in (LATERAL_TRACKING, DLC120) for s in seeds]


ROBUST = Suite(name="robust", description="randomised friction, mass, speed, noise and delay over fixed seeds",
               episodes=robust_episodes, seeds=ROBUST_SEEDS, quick_seeds=ROBUST_SEEDS[:1])
