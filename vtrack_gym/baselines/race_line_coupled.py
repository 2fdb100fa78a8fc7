"""The coupled form of the race baseline ``raceline``: the racing line and its g-g speed profile tracked by the
coupled NMPC (``nmpc_coupled``), which plans steering and longitudinal demand together.

``raceline_coupled`` reads the car's pose from the race observation and re-references it to the env's racing line
exactly as ``raceline`` does (``race_line.LineFollower``: the same line, the same quasi-steady-state profile with
``grip_scale`` and ``brake_scale``); the re-referenced observation (e_y, e_phi, rates, the line's curvature and its
preview, the profile's speed and its preview, ``speed_error`` = v_x - v_profile) goes to the coupled NMPC instead of
a steering law and the feed-forward/P speed law. A race has no time law to keep to: ``time_error`` is 0 and the
NMPC's time weight defaults to 0 here (``RACE_NMPC``); the speed weight pulls the car to the profile, the braking
zones included; the model knows the brakes' grip limit and the friction ellipse.

Its profile is ``raceline``'s at ``grip_scale`` 0.97 and ``brake_scale`` 0.85 (preset ``default``; ``raceline``
runs at 1 and 1): the model caps the brakes at mu m g, not at the car's brake balance (``vehicle.brake_balance``),
and its axle loads are static, so its speed weight brakes harder into a corner than the rear axle can carry; with
``brake_scale`` 1 it spins out on ``vtrack/RaceRing-v0`` at every ``grip_scale`` from 0.94 to 1. ``steering``,
``speed_gain_per_s`` and ``preview_s`` of ``LineFollowerConfig`` are not used (the NMPC replaces both laws).

The line's station is found by projecting the pose with a first guess from the centre line's station map,
interpolated the short way round the lap where the map wraps to 0 (``_station_guess``).

Only in the race env in ``control="steer_accel"`` (as ``raceline``). The policy keeps the NMPC's plan: pass
``episode_start`` (or call ``reset()``) when an episode starts, or use the SB3 state protocol.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, ClassVar

import numpy as np

from vtrack_gym.baselines.nmpc_coupled import CoupledNMPC, CoupledNMPCConfig
from vtrack_gym.baselines.race_line import LineFollower, LineFollowerConfig

RACE_NMPC = CoupledNMPCConfig(weight_time=0.0)
"""The coupled NMPC's parameters on the race: no time error to track."""


class CoupledRaceLine(LineFollower):
    """The env's racing line at the car's limit profile, tracked by the coupled NMPC (module docstring)."""

    name: ClassVar[str] = "raceline_coupled"
    line_kind: ClassVar[str] = "raceline"
    PRESETS: ClassVar[dict[str, LineFollowerConfig]] = {
        "default": LineFollowerConfig(grip_scale=0.97, brake_scale=0.85)}

    def __init__(self, env: Any, config: Any = None, nmpc: CoupledNMPCConfig = RACE_NMPC) -> None:
        super().__init__(env, config)
        if self.control != "steer_accel":
            raise ValueError(f"raceline_coupled drives only in control='steer_accel' (the coupled NMPC plans the "
                             f"steering command itself; got control={self.control!r})")
        base = getattr(env, "unwrapped", env)
        self.inner_layout = dataclasses.replace(base.config.layout, tracking_errors=True)
        self.nmpc = CoupledNMPC(base.design_model, nmpc, self.inner_layout, base.control_period_s,
                                vehicle=base.config.vehicle)
        self.state_size = self.nmpc.state_size
        self._errors = (self.inner_layout.index("speed_error"), self.inner_layout.index("time_error"))

    @property
    def last_solver_stats(self) -> dict[str, float]:
        """The coupled NMPC's statistics of the last decision (``nmpc_rti.STAT_NAMES``)."""
        return self.nmpc.last_solver_stats

    @property
    def solver_failures(self) -> int:
        """The coupled NMPC's failed QPs so far."""
        return self.nmpc.solver_failures

    def reset(self) -> None:
        """Forget the NMPC's plan (a new episode)."""
        self.nmpc.reset()

    def predict(self, observation: Any, state: Any = None, episode_start: Any = None,
                deterministic: bool = True) -> tuple[np.ndarray, Any]:
        """[steering command, longitudinal demand] for one observation (shape (2,)) or a batch ((n, 2)), and the
        NMPC's state (``CoupledNMPC.predict``'s contract)."""
        obs = np.asarray(observation, dtype=np.float64)
        inner = np.array([self._line_obs(row) for row in np.atleast_2d(obs)])
        action, new_state = self.nmpc.predict(inner[0] if obs.ndim == 1 else inner, state, episode_start)
        return action, new_state

    def _station_guess(self, s_c: float) -> float:
        """The line's station [m] near centre-line station ``s_c`` [m]: the station map interpolated between its
        two neighbouring samples the short way round the lap (the map wraps from the line's end to 0 where the
        two lines' starts differ)."""
        s_map, line_map = self._guess
        i = min(int(s_c // (s_map[1] - s_map[0])), s_map.size - 1)
        j = (i + 1) % s_map.size
        span = (s_map[j] if j else self.centre.length_m) - s_map[i]
        frac = (s_c - s_map[i]) / span
        step = math.remainder(line_map[j] - line_map[i], self.line.length_m)
        return float((line_map[i] + frac * step) % self.line.length_m)

    def _line_state(self, row: np.ndarray) -> tuple[float, float, float, float, float]:
        """The car on the line: its station s [m], e_y [m], e_phi [rad], station rate [m/s] and the profile's
        acceleration there [m/s^2] (the pose from the centre-line errors, projected as ``raceline`` does)."""
        idx = self._idx
        s_c = row[idx["lap_fraction"]] * self.centre.length_m
        c = self.centre.sample(s_c)
        e_y, psi = row[idx["e_y"]], float(c.psi) + row[idx["e_phi"]]
        x, y = float(c.x) - math.sin(float(c.psi)) * e_y, float(c.y) + math.cos(float(c.psi)) * e_y
        p = self.line.project(x, y, self._station_guess(s_c), self.config.search_m)
        s_r, ey_r, kappa = float(p.s[0]), float(p.e_y[0]), float(p.kappa[0])
        ephi_r = math.remainder(psi - float(p.psi_ref[0]), 2.0 * math.pi)
        v_x, v_y = row[idx["v_x"]], row[idx["v_y"]]
        s_dot = (v_x * math.cos(ephi_r) - v_y * math.sin(ephi_r)) / max(1.0 - kappa * ey_r, 0.1)
        return s_r, ey_r, ephi_r, s_dot, self._profile(s_r)[1]

    def _line_obs(self, row: np.ndarray) -> np.ndarray:
        """The NMPC's observation of one race observation row, re-referenced to the racing line."""
        idx = self._idx
        s_r, ey_r, ephi_r, s_dot, a_p = self._line_state(row)
        out = self._inner_obs(row, s_r, ey_r, ephi_r, s_dot, a_p)
        out[self._errors[0]] = row[idx["v_x"]] - self._profile(s_r)[0]
        out[self._errors[1]] = 0.0
        return out
