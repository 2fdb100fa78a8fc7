"""Race baselines: a line and a speed profile at the car's limit, tracked by a steering law and a longitudinal law
(the decoupled form). ``raceline``: the env's racing line (``tracks.raceline``, the minimum-curvature line the
env's lap-time bound drives) at the car's quasi-steady-state profile along it (``tracks.lap_time``);
``centreline``: the track's centre line at the same car's profile along the centre line.

Localisation: the race observation (``envs.race_layout``) gives the car's centre-line station (``lap_fraction``)
and its errors to the centre line (``e_y``, ``e_phi``); the policy rebuilds the car's pose from them and its map of
the track (the env's centre line, read when the policy is made), projects the pose on its own line and hands the
steering law (``steering``: ``lqr`` by default, or another stateless steering baseline of the registry) an
observation re-referenced to that line: e_y, e_phi, their rates, the line's curvature and its preview, the
profile's speed and its preview.

Longitudinal law: the profile's speed v_p and acceleration a_p = d(v_p^2)/ds / 2, read ``preview_s`` [s] ahead of
the car's station on the line; the command a = a_p + ``speed_gain_per_s`` (v_p - v_x) [m/s^2], mapped to the
pedals through the car's own longitudinal model: the net force F = m a + R(v) (drag and rolling resistance);
F >= 0 is the throttle fraction F / F_drive,max(v); F < 0 the brake pedal force -F / pedal_gain; as the demand of
the throttle/brake map (``envs.control``). ``grip_scale`` (<= 1) scales the car's lateral, forward and braking
limits of the profile (1: the bound's own profile).

Only in the race env (``vtrack/Race-v0``) in ``control="steer_accel"``; a ``ValueError`` names it for an env
without ``lap_fraction`` or in ``steer_rate_accel``. The coupled form (a nonlinear MPC planning steering and
longitudinal force together) is not provided.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from vtrack_gym._ranges import documented, ranged, validate

STATION_WINDOW_M = 60.0
"""Search window [m] of the line's station nearest each centre-line station, around the proportional guess."""
STEERING_LAWS: tuple[str, ...] = ("lqr", "stanley", "pure_pursuit", "smc")
"""Stateless steering baselines a line follower can use."""


@documented
@dataclass(frozen=True)
class LineFollowerConfig:
    """``steering`` (``STEERING_LAWS``), ``grip_scale`` (the profile's limits scaled by it), ``speed_gain_per_s``
    [1/s], ``preview_s`` [s] (the profile read this far ahead) and ``search_m`` [m] (the projection window)."""

    steering: str = "lqr"
    grip_scale: float = ranged(0.97, ge=0.5, le=1.0)
    brake_scale: float = ranged(0.7, ge=0.2, le=1.0)
    speed_gain_per_s: float = ranged(2.0, ge=0.0, le=20.0, unit="1/s")
    preview_s: float = ranged(0.1, ge=0.0, le=1.0, unit="s")
    search_m: float = ranged(15.0, ge=2.0, le=100.0, unit="m")

    def __post_init__(self) -> None:
        validate(self)
        if self.steering not in STEERING_LAWS:
            raise ValueError(f"steering must be one of {', '.join(STEERING_LAWS)} (got {self.steering!r})")


def scaled_limits(limits: Any, scale: float, brake_scale: float = 1.0) -> Any:
    """``limits`` (``GGLimits``) with the lateral and forward accelerations times ``scale`` and the braking ones
    times ``scale * brake_scale``."""
    from vtrack_gym.tracks.gg_limits import GGLimits

    if scale == 1.0 and brake_scale == 1.0:
        return limits
    return GGLimits(limits.speeds_mps, scale * limits.lateral_mps2, scale * limits.forward_mps2,
                    scale * brake_scale * limits.brake_mps2, limits.top_speed_mps,
                    f"{limits.name} x {scale:g} (braking x {scale * brake_scale:g})")


class LineFollower:
    """A line and its speed profile tracked by a steering law and a longitudinal law (module docstring)."""

    name: ClassVar[str] = "line_follower"
    line_kind: ClassVar[str] = "raceline"
    PRESETS: ClassVar[dict[str, LineFollowerConfig]] = {"default": LineFollowerConfig()}
    action_dim = 2
    state_size = 0

    def __init__(self, env: Any, config: LineFollowerConfig | None = None) -> None:
        from vtrack_gym.baselines.registry import policy_class
        from vtrack_gym.tracks.gg_limits import gg_limits
        from vtrack_gym.tracks.lap_time import QuasiSteadyState

        base = getattr(env, "unwrapped", env)
        self.config = config or LineFollowerConfig()
        layout = getattr(base, "observation_layout", None)
        if layout is None or "lap_fraction" not in layout.names or not hasattr(base, "race_line"):
            raise ValueError(f"{self.name} drives the race env (vtrack/Race-v0): it needs the observation's "
                             "lap_fraction and the env's racing line")
        if getattr(base, "control", None) != "steer_accel":
            raise ValueError(f"{self.name} sends a steering command: it drives the race env made with "
                             f"control='steer_accel' (got control={getattr(base, 'control', None)!r})")
        vehicle = base.config.vehicle
        self.centre = base.paths[0]
        self.line = base.race_line.path if self.line_kind == "raceline" else self.centre
        self.table = QuasiSteadyState(scaled_limits(gg_limits(vehicle), self.config.grip_scale,
                                                        self.config.brake_scale)).row_speeds(self.line)
        self.inner_layout = base.config.layout
        self.steer = policy_class(self.config.steering).from_env(_Contract(base, self.inner_layout))
        self._idx = {n: layout.index(n) for n in ("e_y", "e_phi", "v_x", "v_y", "yaw_rate", "road_wheel_angle",
                                                  "lap_fraction")}
        self._car = _Car.of(vehicle)
        self._guess = self._station_map()

    @classmethod
    def from_env(cls, env: Any, preset: str = "default", **overrides: Any) -> LineFollower:
        """The policy for ``env`` from a preset (``default``) and ``LineFollowerConfig`` field overrides."""
        import dataclasses

        if preset not in cls.PRESETS:
            raise ValueError(f"unknown preset {preset!r} of {cls.name}; valid: {', '.join(cls.PRESETS)}")
        return cls(env, dataclasses.replace(cls.PRESETS[preset], **overrides))

    @classmethod
    def preset_names(cls) -> tuple[str, ...]:
        """The presets (``default``)."""
        return tuple(cls.PRESETS)

    @classmethod
    def make_config(cls, preset: str = "default", **overrides: Any) -> LineFollowerConfig:
        """The config of a preset with field overrides."""
        import dataclasses

        return dataclasses.replace(cls.PRESETS[preset], **overrides)

    @property
    def policy_id(self) -> str:
        """The policy's name."""
        return self.name

    def reset(self) -> None:
        """Nothing to forget: the policy is stateless."""

    def _station_map(self) -> tuple[np.ndarray, np.ndarray]:
        """(centre-line stations, the line's station nearest each) every metre, for the projection's first guess."""
        s_c = np.arange(0.0, self.centre.length_m, 1.0)
        row = self.centre.sample(s_c)
        guess = s_c * (self.line.length_m / self.centre.length_m)   # no KD-tree: the policy's state stays plain data
        return s_c, self.line.project(row.x, row.y, guess, STATION_WINDOW_M).s

    def predict(self, observation: Any, state: Any = None, episode_start: Any = None,
                deterministic: bool = True) -> tuple[np.ndarray, None]:
        """[steering command, longitudinal demand] for one observation (shape (2,)) or a batch ((n, 2))."""
        obs = np.asarray(observation, dtype=np.float64)
        rows = np.atleast_2d(obs)
        out = np.array([self._act(row) for row in rows], dtype=np.float32)
        return (out[0] if obs.ndim == 1 else out), None

    def _act(self, row: np.ndarray) -> tuple[float, float]:
        idx = self._idx
        s_c = row[idx["lap_fraction"]] * self.centre.length_m
        c = self.centre.sample(s_c)
        e_y, psi = row[idx["e_y"]], float(c.psi) + row[idx["e_phi"]]
        x, y = float(c.x) - math.sin(float(c.psi)) * e_y, float(c.y) + math.cos(float(c.psi)) * e_y
        guess = np.interp(s_c, self._guess[0], self._guess[1], period=self.centre.length_m)
        p = self.line.project(x, y, guess, self.config.search_m)
        s_r, ey_r, kappa = float(p.s[0]), float(p.e_y[0]), float(p.kappa[0])
        ephi_r = math.remainder(psi - float(p.psi_ref[0]), 2.0 * math.pi)
        v_x, v_y = row[idx["v_x"]], row[idx["v_y"]]
        s_dot = (v_x * math.cos(ephi_r) - v_y * math.sin(ephi_r)) / max(1.0 - kappa * ey_r, 0.1)
        v_p, a_p = self._profile(s_r + max(v_x, 0.0) * self.config.preview_s)
        inner = self._inner_obs(row, s_r, ey_r, ephi_r, s_dot, a_p)
        steer = float(np.asarray(self.steer.predict(inner)[0]).reshape(-1)[0])
        a_cmd = a_p + self.config.speed_gain_per_s * (v_p - v_x)
        return steer, self._car.demand(a_cmd, v_x)

    def _profile(self, s: float) -> tuple[float, float]:
        """(speed [m/s], acceleration [m/s^2]) of the profile at the line's station ``s`` [m]."""
        ds, n = self.line.ds_m, self.table.size - 1
        u = s % self.line.length_m / ds
        i = min(int(u), n - 1)
        v2a, v2b = self.table[i] ** 2, self.table[i + 1] ** 2
        return math.sqrt(v2a + (u - i) * (v2b - v2a)), (v2b - v2a) / (2.0 * ds)

    def _inner_obs(self, row: np.ndarray, s_r: float, ey_r: float, ephi_r: float, s_dot: float,
                   a_p: float) -> np.ndarray:
        """The steering law's observation re-referenced to the line (the env's base layout)."""
        from vtrack_gym.envs.kernels import write_scalar_fields

        lay, idx = self.inner_layout, self._idx
        out = np.zeros(lay.size, dtype=np.float64)
        sample = self.line.sample(s_r)
        v_x = row[idx["v_x"]]
        v_p = self._profile(s_r)[0]
        write_scalar_fields(out, ey_r, ephi_r, v_x, row[idx["v_y"]], row[idx["yaw_rate"]],
                            row[idx["road_wheel_angle"]], v_p, float(sample.kappa), float(sample.dkappa), s_dot, a_p)
        out[lay.preview] = self.line.preview(s_r, lay.preview_distances(v_x))[0]
        if lay.n_speed_preview:
            ahead = s_r + lay.speed_preview_distances(v_x)
            out[lay.speed_preview] = [self._profile(float(s))[0] for s in ahead]
        return out

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.config})"


class RaceLine(LineFollower):
    """The env's minimum-curvature racing line at the car's limit profile along it (module docstring)."""

    name: ClassVar[str] = "raceline"
    line_kind: ClassVar[str] = "raceline"


class CentreLine(LineFollower):
    """The track's centre line at the car's limit profile along it (module docstring)."""

    name: ClassVar[str] = "centreline"
    line_kind: ClassVar[str] = "centreline"


@dataclass(frozen=True)
class _Car:
    """The car's longitudinal figures the pedal map needs."""

    mass_kg: float
    pedal_gain: float
    max_pedal_force_n: float
    vehicle: Any

    @classmethod
    def of(cls, vehicle: Any) -> _Car:
        return cls(vehicle.chassis.mass_kg, vehicle.brakes.pedal_gain, vehicle.brakes.max_pedal_force_n, vehicle)

    def demand(self, accel_mps2: float, v_mps: float) -> float:
        """The longitudinal demand in [-1, 1] for an acceleration ``accel_mps2`` at speed ``v_mps``."""
        from vtrack_gym.vehicle.longitudinal import drive_force_n, resistance_n

        force = self.mass_kg * accel_mps2 + float(resistance_n(self.vehicle, v_mps))
        if force >= 0.0:
            return min(force / float(drive_force_n(self.vehicle, v_mps)), 1.0)
        return max(force / (self.pedal_gain * self.max_pedal_force_n), -1.0)


class _Contract:
    """What a steering law's ``from_env`` reads of an env: the race env's design model and period, the base
    layout."""

    def __init__(self, base: Any, layout: Any) -> None:
        self.design_model = base.design_model
        self.observation_layout = layout
        self.control_period_s = base.control_period_s
        self.control = "steer"
