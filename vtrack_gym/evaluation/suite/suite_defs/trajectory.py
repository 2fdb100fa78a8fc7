"""``trajectory``: trajectory tracking in space and time with the agent on the pedals (``control="steer_accel"``):
the paper's two scenarios, three manoeuvres (ISO 3888-1 and -2 double lane changes, slalom) and three courses with
a speed profile that varies along them (``envs.circuits``: the handling course, the example map's ring, a
procedural road). Seed 0 (deterministic without noise). Ranked by success, then max |e_y|, then the RMS speed
error; the board also shows the speed error's maximum and the time lag at the end.

A course that holds one set speed from rest (``LateralTracking-v0``) is driven with ``launch="powertrain"``
(``envs.launch``): its reference leaves the line on a ramp the car's powertrain can follow, as the courses' own
profiles do, so the speed and time errors measure following the reference, not the car's launch (the step's
2.7 s at full throttle alone is 0.725 m/s RMS over the lap). Its rows record the launch (``options["protocol"]``)."""

from __future__ import annotations

from vtrack_gym.envs.circuits import CIRCUIT_IDS
from vtrack_gym.evaluation.rollouts.episodes import Episode
from vtrack_gym.evaluation.suite.suite_parts import Suite

TRAJECTORY_CONTROL = "steer_accel"
"""The control mode every episode of the suite is driven in (``envs.control``)."""
TRAJECTORY_ENV_IDS: tuple[str, ...] = ("LateralTracking-v0", "DLC120-v0", "vtrack/ISO3888-1-v1",
                                       "vtrack/ISO3888-2-v1", "vtrack/Slalom-v1", *CIRCUIT_IDS)
"""Env ids of the ``trajectory`` suite: the paper scenarios, three manoeuvres, three courses."""
TRAJECTORY_COLUMNS: tuple[str, ...] = ("rms_e_v_mps", "max_e_v_mps", "time_lag_s")
"""Board columns beyond the common ones: RMS and largest speed error [m/s], time lag at the end [s]."""


TRAJECTORY_LAUNCH = "powertrain"
"""How the reference of a course that holds one set speed from rest leaves the start (``envs.launch``)."""


def trajectory_episodes(seeds: tuple[int, ...]) -> list[Episode]:
    """Every env of ``TRAJECTORY_ENV_IDS`` at each seed, in ``TRAJECTORY_CONTROL``, a held speed from rest with
    ``TRAJECTORY_LAUNCH``."""
    from vtrack_gym.evaluation.rollouts.episodes import with_launch

    plain = [Episode(env_id, s, control=TRAJECTORY_CONTROL) for s in seeds for env_id in TRAJECTORY_ENV_IDS]
    return with_launch(plain, TRAJECTORY_LAUNCH, where_it_applies=True)


TRAJECTORY = Suite(name="trajectory", description="steer_accel: paper scenarios, ISO 3888-1/-2, slalom and three "
                   "courses with a varying speed profile; ranked by success, max|e_y|, then RMS speed error",
                   episodes=trajectory_episodes, primary_metric="max_e_y_m", columns=TRAJECTORY_COLUMNS,
                   then_metrics=("rms_e_v_mps",))
"""The ``trajectory`` suite (see the module docstring)."""
