"""The race's reward (``vtrack/Race-v0``): progress along the track, less time, track-limit and failure penalties.

Per control step of T [s], with L [m] the centre line's lap length and T_b [s] the car's lap-time bound
(``tracks.lap_time``):

    r = w_progress * dp_credited / L  -  w_time * T / T_b  -  w_limits * cost  -  w_failure * [failure]

``dp`` [m] is the centre-line station gained in the step (laps counted; negative when the car goes backwards);
``dp_credited`` is ``dp`` while the car keeps the track-limit rule and ``min(dp, 0)`` on a step that breaks it
(``info["cost"]`` = 1): ground gained beyond the rule is never paid for, ground lost always counts. So a lap
within the rule is worth ``w_progress``; a lap costs ``w_time`` per lap-bound of time spent on it (``w_time`` at
the bound, ``3 w_time`` at the time limit's pace); every step beyond the rule costs ``w_limits`` and a failure
(off the track beyond the rule, spin-out, wheel lift) ``w_failure`` once. Spinning on the spot earns only the time
cost (< 0); driving backwards earns ``-w_progress`` per lap driven backwards, plus the time cost; a cut corner
loses the ground gained off the track and pays ``w_limits`` for each step of it.
"""

from __future__ import annotations

from dataclasses import dataclass

from vtrack_gym._ranges import documented, ranged, validate


@documented
@dataclass(frozen=True)
class RaceReward:
    """Weights of the race's reward (module docstring): per lap of progress, per lap-bound of time, per step beyond
    the track-limit rule, once per failure."""

    w_progress: float = ranged(100.0, gt=0.0, le=1e4)
    w_time: float = ranged(10.0, ge=0.0, le=1e4)
    w_limits: float = ranged(1.0, ge=0.0, le=1e4)
    w_failure: float = ranged(50.0, ge=0.0, le=1e6)

    def __post_init__(self) -> None:
        validate(self)

    def terms(self, progress_m: float, lap_length_m: float, period_s: float, bound_s: float, cost: float,
              failed: bool) -> dict[str, float]:
        """The step's terms (``race_reward_progress``, ``race_reward_time``, ``race_reward_limits``,
        ``race_reward_failure``) for ``progress_m`` [m] of station gained, a lap of ``lap_length_m`` [m], a control
        period ``period_s`` [s], the lap-time bound ``bound_s`` [s], the step's track-limit ``cost`` (0 or 1) and
        whether the episode failed on it."""
        credited = progress_m if cost <= 0.0 else min(progress_m, 0.0)
        return {"race_reward_progress": self.w_progress * credited / lap_length_m,
                "race_reward_time": -self.w_time * period_s / bound_s,
                "race_reward_limits": -self.w_limits * float(cost),
                "race_reward_failure": -self.w_failure if failed else 0.0}


RACE_REWARD_TERMS: tuple[str, ...] = ("race_reward_progress", "race_reward_time", "race_reward_limits",
                                      "race_reward_failure")
"""The ``info`` keys of the race reward's terms (their sum is the step's reward)."""
