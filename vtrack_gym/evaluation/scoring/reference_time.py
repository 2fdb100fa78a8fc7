"""The timed reference of an episode and the time error against it (trajectory tracking in time).

A trajectory is a path and its timing: the reference speed v_ref(s) an episode drives against has a time law
t_ref(s) (``tracks.time_law``). The time error after a control step is

    e_t = time_s - (T(s0 + progress_m) - T(s0)),     T = time_law(speed table).time_at,

with s0 the car's station at the reset; positive: behind the reference (the car needed longer than the reference
to cover the same distance). A row's ``time_lag_s`` is e_t at the episode's last step.

Which speed table an episode's T is built from is the one its env drives against, taken when the episode starts:

* a speed profile followed along the path (``Track-v0`` with a profile, the training mix): the profile's table;
* an ISO 3888 protocol (the PD-FLC holds the entry speed up to the entry gate, then lets go of the pedals): the
  protocol's predicted speed (the entry speed, then the car's own coast, ``EntryThenRelease.time_limit_table``), so
  ``time_lag_s`` there is the departure from the coast the protocol predicts for the car;
* a held speed (the paper's scenarios, a drawn or reset-option set speed): that speed everywhere.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from vtrack_gym.tracks.time_law import TimeLaw


@dataclass(frozen=True, eq=False)
class EpisodeReference:
    """The timed reference of one episode: its time law and the car's station at the reset ``start_station_m``
    [m]."""

    time_law: TimeLaw
    start_station_m: float

    @property
    def closed(self) -> bool:
        """Whether the path is a closed loop (laps are timed)."""
        return bool(self.time_law.table.closed)

    @property
    def length_m(self) -> float:
        """The path's length (one lap on a closed path) [m]."""
        return float(self.time_law.table.length_m)

    def time_error_s(self, time_s: np.ndarray | float, progress_m: np.ndarray | float) -> np.ndarray:
        """e_t = time_s - (T(s0 + progress_m) - T(s0)) [s] at each sample (positive: behind the reference)."""
        s0 = self.start_station_m
        t_ref = self.time_law.time_at(s0 + np.asarray(progress_m, dtype=np.float64)) - self.time_law.time_at(s0)
        return np.asarray(time_s, dtype=np.float64) - t_ref


def _sim_of(env: Any) -> Any:
    """The compiled batch of a vtrack env (single: its private ``_sim``, vector: ``sim``); None for other envs."""
    unwrapped = getattr(env, "unwrapped", env)
    sim = getattr(unwrapped, "_sim", None)
    return getattr(unwrapped, "sim", None) if sim is None else sim


def episode_reference(env: Any, car: int = 0) -> EpisodeReference | None:
    """The timed reference of car ``car``'s episode, read right after ``env.reset`` (rules in the module
    docstring); None for an env that is not a vtrack env (e.g. the highway-env adapter) and for a held speed outside
    a speed table's range (1 to 100 m/s)."""
    sim = _sim_of(env)
    if sim is None or not hasattr(sim, "tracks"):
        return None
    from vtrack_gym.envs.speed import speed_part
    from vtrack_gym.tracks.path import MAX_V_REF_MPS, MIN_V_REF_MPS
    from vtrack_gym.tracks.speed_profiles import ConstantSpeed, speed_table
    from vtrack_gym.tracks.time_law import time_law

    track = int(sim.veh_track[car])
    part = speed_part(sim.scenario.speed)
    set_speed = float(sim.v_ref[car])
    entry = getattr(part, "entry_speed_mps", None) if part.takes_entry_speed else None
    if bool(sim.follow[car]) or (entry is not None and math.isclose(set_speed, entry, rel_tol=1e-12)):
        table = sim.tracks.speed_tables[track]   # the profile, or the protocol's prediction (entry, then coast)
    elif MIN_V_REF_MPS <= set_speed <= MAX_V_REF_MPS:
        table = speed_table(sim.paths[track], ConstantSpeed(set_speed))
    else:
        return None
    return EpisodeReference(time_law(table), float(sim.station_m[car]))


def timing_metrics(reference: EpisodeReference | None, time_s: np.ndarray,
                   progress_m: np.ndarray) -> dict[str, Any]:
    """``time_lag_s`` (e_t at the last step [s], NaN without a reference or a step) and, on a closed path, the lap
    figures (``laps.lap_metrics``: ``lap_times_s``, ``best_lap_s``, ``mean_lap_s``)."""
    from vtrack_gym.evaluation.scoring.laps import lap_metrics

    t = np.asarray(time_s, dtype=np.float64)
    if reference is None or t.size == 0:
        return {"time_lag_s": math.nan}
    p = np.asarray(progress_m, dtype=np.float64)
    out: dict[str, Any] = {"time_lag_s": float(reference.time_error_s(t[-1], p[-1]))}
    if reference.closed:
        out.update(lap_metrics(t, p, reference.length_m))
    return out
