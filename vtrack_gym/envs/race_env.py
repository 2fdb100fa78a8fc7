"""``RaceEnv`` (``vtrack/Race-v0``): the fastest laps within track limits, judged against the car's lap-time bound.

Make kwargs: ``track=`` (any track Track-v0 reads: a built-in closed track, a track file, a ``tracks.Path`` or
the name of a shipped example map, ``"ring.gpx"``; default the handling course; the track must be one closed
path), ``laps=`` (1..20, default 2), ``start=``
(``"standing"``, default, or ``"flying"``: at the reference speed), ``control=`` (``"steer_accel"``, default, or
``"steer_rate_accel"``: the agent drives the pedals; ``"steer"`` is refused), ``track_limits=`` (``"wheels"``,
default, ``"body"`` or ``"centre"``: ``envs.criteria.TrackLimits``), ``time_limit_factor=`` (the time limit is
this many times ``laps`` lap-time bounds, 1.2..10, default 3), ``reward=`` (``RaceReward``), ``margin_m=`` (the
racing line's clearance from the edges for the bound, default 0.2 m) and every ``EnvConfig`` field (``vehicle=``,
``control_period_s=``, ...), the track-reading kwargs of Track-v0 and ``latency=``.

The car, its plant and its pedals are those of the longitudinal control modes (``envs.control``). The reference
speed (``target_speed``, ``speed_error``, ``time_error``) is the car's own quasi-steady-state limit along the
centre line (``tracks.lap_time.QuasiSteadyState``, a flying lap). ``lap_time_bound_s`` [s] is the car's flying-lap
bound on the track's minimum-curvature racing line (``tracks.raceline``, ``tracks.lap_time``), solved once when the
env is made (``race_line`` and ``lap_bound`` keep both).

Observation: the longitudinal modes' layout with ``edge_left_m``, ``edge_right_m`` and ``lap_fraction`` at the end
(``envs.race_layout``). Reward: ``envs.race_reward`` (its terms in ``info``). An episode ends ``completed`` after
``laps`` laps (success: no step broke the track-limit rule), or on a failure (``off_road``: the whole car off,
``spin_out``, ``wheel_lift``), or is truncated at the time limit. Every step's info has ``laps_completed`` and
``lap_time_bound_s``; ``progress_m`` counts the laps; the last step's info has ``lap_times_s`` (a list [s]),
``best_lap_s`` [s] (NaN without a lap) and ``lap_time_fraction`` (best lap / bound).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from vtrack_gym._ranges import documented, ranged, validate
from vtrack_gym.envs.criteria import TrackLimits
from vtrack_gym.envs.race_layout import RaceLayout
from vtrack_gym.envs.race_reward import RaceReward
from vtrack_gym.envs.randomisation import Start
from vtrack_gym.envs.scenarios import MAX_EPISODE_S, Scenario, with_track
from vtrack_gym.envs.track_sources import TrackSource
from vtrack_gym.envs.tracking_env import TrackingEnv, scenario_config

RACE_CONTROLS: tuple[str, ...] = ("steer_accel", "steer_rate_accel")
"""The control modes Race-v0 takes: the agent drives the pedals."""
STARTS: tuple[str, ...] = ("standing", "flying")
"""``start=``: from rest on the line, or at the reference speed."""
DEFAULT_TRACK = "handling_course"
"""Race-v0's default track (a shipped circuit)."""


@documented
@dataclass(frozen=True)
class RaceSettings:
    """The race's own make kwargs: ``laps``, ``start`` (``STARTS``), ``time_limit_factor`` (time limit = factor x
    laps x lap-time bound) and ``margin_m`` [m] (the bound's racing line: clearance between body side and edge)."""

    laps: int = ranged(2, ge=1, le=20, integer=True)
    start: str = "standing"
    time_limit_factor: float = ranged(3.0, ge=1.2, le=10.0)
    margin_m: float = ranged(0.2, ge=0.0, le=5.0, unit="m")

    def __post_init__(self) -> None:
        validate(self)
        if self.start not in STARTS:
            raise ValueError(f"start must be one of {', '.join(map(repr, STARTS))} (got {self.start!r})")


def check_race_control(control: Any) -> str:
    """``control`` if Race-v0 takes it (``RACE_CONTROLS``); ``ValueError`` naming ``control`` and those modes."""
    if control not in RACE_CONTROLS:
        raise ValueError(f"vtrack/Race-v0: control must be one of {', '.join(map(repr, RACE_CONTROLS))} (the agent "
                         f"drives the pedals as well as the steering; got {control!r})")
    return str(control)


def race_bound(path: Any, vehicle: Any, margin_m: float) -> tuple[Any, Any]:
    """(the ``RacingLine`` of ``path`` for ``vehicle``, its ``LapTimeBound`` at the car's g-g-v limits)."""
    from vtrack_gym.tracks.gg_limits import gg_limits
    from vtrack_gym.tracks.lap_time import line_lap_time
    from vtrack_gym.tracks.raceline import RacingLineSpec, solve_racing_line

    line = solve_racing_line(path, vehicle, RacingLineSpec(margin_m=margin_m))
    return line, line_lap_time(line.path, gg_limits(vehicle), "raceline")


def race_scenario(settings: RaceSettings, track_limits: str, track: Any, read: dict[str, Any],
                  overrides: dict[str, Any]) -> tuple[Scenario, Any, Any, Any]:
    """(the scenario, the env config, the racing line, the bound) of a race on ``track``."""
    from vtrack_gym.envs.sim import scenario_tracks
    from vtrack_gym.tracks.example_maps import EXAMPLE_MAPS, example_map
    from vtrack_gym.tracks.gg_limits import gg_limits
    from vtrack_gym.tracks.lap_time import QuasiSteadyState

    if isinstance(track, str) and track in EXAMPLE_MAPS:
        track = str(example_map(track))
    base = Scenario(name="Race-v0", track=TrackSource(track=DEFAULT_TRACK),
                    start=Start(at_speed=settings.start == "flying"), success=TrackLimits(rule=track_limits))
    scenario = with_track(base, track, None, read.pop("half_width_m", None), read.pop("closed", None),
                          read.pop("smoothing_m", None), read)
    config = scenario_config(scenario, None, overrides)
    paths = scenario_tracks(scenario, config.vehicle)
    if len(paths) != 1 or not paths[0].closed:
        raise ValueError(f"vtrack/Race-v0 needs one closed track (got {len(paths)} path(s), "
                         f"closed: {[bool(p.closed) for p in paths]})")
    line, bound = race_bound(paths[0], config.vehicle, settings.margin_m)
    limit = settings.time_limit_factor * settings.laps * bound.lap_time_s
    if limit > MAX_EPISODE_S:
        raise ValueError(f"vtrack/Race-v0: {settings.laps} laps at {settings.time_limit_factor} x the bound "
                         f"{bound.lap_time_s:.1f} s exceed the longest episode, {MAX_EPISODE_S:.0f} s")
    scenario = replace(scenario, speed=QuasiSteadyState(gg_limits(config.vehicle)), time_limit_s=limit)
    return scenario, config, line, bound


class RaceEnv(TrackingEnv):
    """N laps of a closed track within track limits (module docstring)."""

    def __init__(self, track: Any = None, laps: int = 2, start: str = "standing", control: str = "steer_accel",
                 track_limits: str = "wheels", time_limit_factor: float = 3.0, reward: RaceReward | None = None,
                 margin_m: float = 0.2, half_width_m: float | None = None, closed: bool | None = None,
                 smoothing_m: float | None = None, allow_self_crossing: bool | None = None,
                 track_options: dict[str, Any] | None = None, **kwargs: Any) -> None:
        self.settings = RaceSettings(laps=laps, start=start, time_limit_factor=time_limit_factor, margin_m=margin_m)
        self.reward_config = RaceReward() if reward is None else reward
        if not isinstance(self.reward_config, RaceReward):
            raise ValueError(f"reward must be a RaceReward (got {type(reward).__name__})")
        check_race_control(control)
        env_kwargs = {k: kwargs.pop(k) for k in ("render_mode", "render_fps", "render_view", "latency", "latency_s",
                                                 "latency_clock") if k in kwargs}
        read = {"half_width_m": half_width_m, "closed": closed, "smoothing_m": smoothing_m,
                "allow_self_crossing": allow_self_crossing, "track_options": track_options}
        scenario, config, self.race_line, self.lap_bound = race_scenario(
            self.settings, track_limits, track, read, {**kwargs, "control": control})
        super().__init__(scenario, config=config, **env_kwargs)
        self.observation_layout = RaceLayout.of(config.layout)
        self.observation_space = _race_space(self.observation_layout)
        self.lap_time_bound_s = float(self.lap_bound.lap_time_s)
        """The car's flying-lap bound on the racing line [s]."""
        self.lap_length_m = float(self.paths[0].length_m)
        self._offset_m = 0.0
        self._crossings: list[float] = []

    # ------------------------------------------------------------------ episode
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        obs, info = super().reset(seed=seed, options=options)
        self._offset_m = 0.0
        self._crossings = []
        self._add_info(info, ended=False)
        return self._race_obs(obs), info

    def step(self, action: Any):
        from vtrack_gym.envs import kernels as k

        sim = self._sim
        period = self.control_period_s
        before = self._offset_m + float(sim.progress[0])
        obs, _, terminated, truncated, info = super().step(action)
        after = self._offset_m + float(sim.progress[0])
        line = (len(self._crossings) + 1) * self.lap_length_m
        if after >= line > before:
            t1 = int(sim.steps[0]) * period
            self._crossings.append(t1 - period + period * (line - before) / (after - before))
            if len(self._crossings) < self.settings.laps and info["termination"] == "completed":
                sim.car[0, k.CAR_PROGRESS] -= self.lap_length_m    # the next lap: the time law's origin moves
                sim.car[0, k.CAR_T0] -= sim.arrays.tmeta[0, k.TM_LAP_T]   # by one lap too (e_t unchanged)
                self._offset_m += self.lap_length_m
                terminated, self._needs_reset = False, bool(truncated)
                info["termination"], info["success"] = "", False
        failed = bool(terminated) and info["termination"] != "completed"
        terms = self.reward_config.terms(after - before, self.lap_length_m, period, self.lap_time_bound_s,
                                         float(info["cost"]), failed)
        info.update(terms)
        info["progress_m"] = np.float64(after)
        self._add_info(info, ended=bool(terminated or truncated))
        return self._race_obs(obs), float(sum(terms.values())), terminated, truncated, info

    # ------------------------------------------------------------------ outputs
    def lap_times_s(self) -> list[float]:
        """The completed laps' times so far [s] (lap 1 from the reset)."""
        return [float(b - a) for a, b in zip([0.0, *self._crossings], self._crossings, strict=False)]

    def _add_info(self, info: dict[str, Any], ended: bool) -> None:
        info["laps_completed"] = len(self._crossings)
        info["lap_time_bound_s"] = self.lap_time_bound_s
        if ended:
            laps = self.lap_times_s()
            best = min(laps) if laps else math.nan
            info["lap_times_s"] = laps
            info["best_lap_s"] = best
            info["lap_time_fraction"] = best / self.lap_time_bound_s

    def _race_obs(self, obs: np.ndarray) -> np.ndarray:
        from vtrack_gym.envs import kernels as k

        err = self._sim.err[0]
        extra = (err[k.E_WL] - err[k.E_EY], err[k.E_WR] + err[k.E_EY],
                 (err[k.E_S] % self.lap_length_m) / self.lap_length_m)
        return np.concatenate((obs, np.clip(np.array(extra, dtype=np.float32), -200.0, 200.0)))

    def success_metrics(self) -> dict[str, float]:
        """The track-limit figures (``track_limit_violations``, ``min_edge_margin_m``), ``lap_time_bound_s`` [s],
        ``lap_time_fraction`` (best lap / bound; NaN without a lap) and ``laps_completed`` of the episode."""
        laps = self.lap_times_s()
        best = min(laps) if laps else math.nan
        return {**super().success_metrics(), "lap_time_bound_s": self.lap_time_bound_s,
                "lap_time_fraction": best / self.lap_time_bound_s, "laps_completed": float(len(laps))}


def _race_space(layout: RaceLayout) -> Any:
    """The float32 observation box of the race layout."""
    import gymnasium as gym

    low, high = layout.bounds()
    return gym.spaces.Box(low, high, dtype=np.float32)
