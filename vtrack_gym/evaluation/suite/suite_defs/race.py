"""``race``: two laps from a standing start on each shipped circuit (``vtrack/Race-v0`` on the handling course,
``vtrack/RaceRing-v0`` on the example ring, ``vtrack/RaceFS-v0``: the Formula Student car on the cone-lined AMZ FSI
layout), within the wheels track-limit rule, the sensors at their nominal noise (``sensor_noise`` 1) so that seeds
differ. Ranks on the best lap as a fraction of the car's lap-time bound (``lap_time_fraction``, lower is better);
the board also shows the lap times, the bound, the track-limit excursions and the least edge margin.
"""

from __future__ import annotations

from vtrack_gym.evaluation.rollouts.episodes import Episode
from vtrack_gym.evaluation.suite.suite_parts import Suite

RACE_ENV_IDS: tuple[str, ...] = ("vtrack/Race-v0", "vtrack/RaceRing-v0", "vtrack/RaceFS-v0")
"""The race suite's circuits."""
RACE_SEEDS: tuple[int, ...] = (0, 1, 2)
"""Seeds of the race suite (the sensor noise's draws)."""
RACE_OPTIONS: dict[str, float] = {"sensor_noise": 1.0}
"""Reset options of every race episode."""


def race_episodes(seeds: tuple[int, ...] = RACE_SEEDS) -> list[Episode]:
    """Every circuit at each seed, in the race's own control mode (``steer_accel``)."""
    return [Episode(env_id, s, dict(RACE_OPTIONS), control="steer_accel") for s in seeds for env_id in RACE_ENV_IDS]


RACE = Suite(name="race", description="two laps of each shipped circuit within track limits, against the lap-time "
                                      "bound", episodes=race_episodes, seeds=RACE_SEEDS, quick_seeds=RACE_SEEDS[:1],
             primary_metric="lap_time_fraction",
             columns=("lap_time_bound_s", "lap_time_fraction", "laps_completed"), figures="tracking")
"""The ``race`` suite (module docstring)."""
