"""The speed protocol of a scenario (a scenario part): hold a set speed, or follow a speed profile along the path.

A scenario's ``speed`` is a ``HoldSpeed`` (the paper's scenarios: the PD-FLC holds one reference speed, optionally
drawn per episode), an ``EntryThenRelease`` (the ISO 3888 protocols: the PD-FLC holds the entry speed on the
approach, then lets go of the pedals at the entry gate) or any ``tracks`` speed profile (``ConstantSpeed``,
``CurvatureLimited``, ``FileSpeed``, the training mix's), whose v_ref(s) the PD-FLC follows at the car's station.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from vtrack_gym._ranges import documented, ranged, validate
from vtrack_gym.tracks.maneuvers import MAX_ENTRY_SPEED_KMH
from vtrack_gym.vehicle.params import GRAVITY_MPS2

FEASIBLE_LATERAL_ACC_MPS2 = 0.85 * GRAVITY_MPS2
"""A randomised set speed is capped at sqrt(this / peak curvature) of the drawn track [m/s^2] (DLC120-v0's centre
line peaks at 0.81 g): an infeasible episode teaches nothing but spinning out."""


@documented
@dataclass(frozen=True, kw_only=True)
class HoldSpeed:
    """Hold ``target_speed_mps``; with ``random_range_mps`` (low, high) a set speed is drawn per episode instead,
    uniform in the range capped so the track's tightest curve needs at most ``FEASIBLE_LATERAL_ACC_MPS2``."""

    target_speed_mps: float = ranged(gt=0.0, le=45.0, unit="m/s")
    random_range_mps: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        validate(self)
        r = self.random_range_mps
        if r is not None and not (isinstance(r, tuple) and len(r) == 2
                                  and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in r)
                                  and 0.0 < r[0] <= r[1] <= 45.0):
            raise ValueError(f"HoldSpeed.random_range_mps must be None or (low, high) with 0 < low <= high <= 45 "
                             f"m/s (got {r!r})")

    def held_set_speed_mps(self) -> float | None:
        """The one set speed [m/s] held through the episode, or None when it is drawn per episode (an optional
        capability of a speed part: ``envs.launch`` ramps up to it from rest)."""
        return None if self.random_range_mps is not None else float(self.target_speed_mps)

    def set_speed_mps(self, peak_curvature_per_m: float, rng: np.random.Generator) -> float:
        """The episode's set speed [m/s] on a track of this peak |curvature| [1/m]."""
        if self.random_range_mps is None:
            return self.target_speed_mps
        lo, hi = self.random_range_mps
        if peak_curvature_per_m > 0.0:
            hi = max(lo, min(hi, float(np.sqrt(FEASIBLE_LATERAL_ACC_MPS2 / peak_curvature_per_m))))
        return float(rng.uniform(lo, hi))

    follows_profile: ClassVar[bool] = False
    takes_entry_speed: ClassVar[bool] = False

    def tables(self, paths: tuple, vehicle: Any = None) -> tuple:
        """The held speed everywhere, one ``tracks.SpeedTable`` per path."""
        from vtrack_gym.tracks.speed_profiles import ConstantSpeed, speed_table

        return tuple(speed_table(p, ConstantSpeed(self.target_speed_mps)) for p in paths)

    def release_columns(self, paths: tuple) -> np.ndarray:
        """The PD-FLC never lets go: (K, 2) of (+inf, 0)."""
        return _never_released(paths)

    def nominal_speed_mps(self, tables: tuple) -> float:
        """The held speed [m/s]."""
        return self.target_speed_mps

    def start_speed_mps(self, peak_curvature_per_m: float, table: Any, rng: np.random.Generator) -> float:
        """The episode's set speed [m/s] (``set_speed_mps``)."""
        return self.set_speed_mps(peak_curvature_per_m, rng)

    def check_for_car(self, vehicle: Any) -> None:
        """A held speed fits any car (its feasibility cap is applied per track when drawn)."""


AFTER_ENTRY: dict[str, str] = {
    "coast": "throttle 0 and brake 0 from the entry gate on (ISO 3888-2: the throttle released at the entry)",
    "hold_throttle": "the throttle frozen at its value when the car crossed the entry gate, brake 0 (ISO 3888-1 "
                     "holds the throttle)",
}
"""What the pedals do after the entry gate under ``EntryThenRelease`` (its ``after_entry``)."""
RELEASE_MODES: dict[str, float] = {"coast": 0.0, "hold_throttle": 1.0}
"""``after_entry`` -> the code the compiled step reads (``kernels.TM_RELEASE_HOLD``)."""
MIN_TIME_LIMIT_SPEED_MPS = 1.0
"""Floor of the predicted coasting speed [m/s] when an ``EntryThenRelease`` time limit is derived (a car that
coasts to a stop is truncated, not run for ever)."""


@documented
@dataclass(frozen=True, kw_only=True)
class EntryThenRelease:
    """The ISO 3888 speed protocol: the car starts at ``entry_speed_kmh`` [km/h], the PD-FLC holds it on the
    approach, and from the entry gate (the path's first gate's ``s_start_m``) the PD-FLC is off and the pedals do
    what ``after_entry`` says (``AFTER_ENTRY``: ``"coast"`` or ``"hold_throttle"``).

    After the entry gate the observation's ``target_speed`` (and its speed preview, and
    ``info["target_speed_mps"]``) show the car's own speed v_x: no speed loop acts, so the speed the car keeps is
    the only set point there is. The range is checked against the driven car by ``feasibility.check_entry_speed``
    when the env is made (this class only refuses what no car accepts)."""

    entry_speed_kmh: float = ranged(gt=0.0, le=MAX_ENTRY_SPEED_KMH, unit="km/h")
    after_entry: str = "coast"

    def __post_init__(self) -> None:
        validate(self)
        if self.after_entry not in AFTER_ENTRY:
            raise ValueError(f"EntryThenRelease.after_entry must be one of {sorted(AFTER_ENTRY)} "
                             f"(got {self.after_entry!r})")

    @property
    def entry_speed_mps(self) -> float:
        """The entry speed [m/s]."""
        return self.entry_speed_kmh / 3.6

    @staticmethod
    def release_station_m(path: Any) -> float:
        """Station of the entry gate on ``path`` [m] (its first gate's start); ValueError for a path without gates."""
        if not path.gates:
            raise ValueError(f"EntryThenRelease needs a path with cone gates (the entry gate); track {path.name!r} "
                             "has none")
        return float(path.gates[0].s_start_m)

    def time_limit_table(self, path: Any, vehicle: Any) -> Any:
        """A ``tracks.SpeedTable`` of the speed the protocol predicts (entry speed up to the entry gate, then the
        car's coast, ``feasibility.coast_speed_mps``, or the entry speed held with the throttle), floored at
        ``MIN_TIME_LIMIT_SPEED_MPS``: what the derived time limit is computed from. The PD-FLC never reads it."""
        from vtrack_gym.tracks.feasibility import coast_speed_mps
        from vtrack_gym.tracks.speed_profiles import ConstantSpeed, SpeedTable

        s = np.arange(path.n_samples) * path.ds_m
        v = np.full(path.n_samples, self.entry_speed_mps)
        after = s > self.release_station_m(path)
        if self.after_entry == "coast" and vehicle is not None:
            v[after] = coast_speed_mps(vehicle, self.entry_speed_mps, s[after] - self.release_station_m(path))
        return SpeedTable(np.maximum(v, MIN_TIME_LIMIT_SPEED_MPS), path.ds_m, path.closed,
                          ConstantSpeed(self.entry_speed_mps))

    follows_profile: ClassVar[bool] = False
    takes_entry_speed: ClassVar[bool] = True

    def tables(self, paths: tuple, vehicle: Any = None) -> tuple:
        """The predicted speed for ``vehicle`` per path (``time_limit_table``)."""
        return tuple(self.time_limit_table(p, vehicle) for p in paths)

    def release_columns(self, paths: tuple) -> np.ndarray:
        """(K, 2): the entry gate's station [m] and the pedal mode after it (``RELEASE_MODES``)."""
        out = _never_released(paths)
        out[:, 0] = [self.release_station_m(p) for p in paths]
        out[:, 1] = RELEASE_MODES[self.after_entry]
        return out

    def nominal_speed_mps(self, tables: tuple) -> float:
        """The entry speed [m/s]."""
        return self.entry_speed_mps

    def start_speed_mps(self, peak_curvature_per_m: float, table: Any, rng: np.random.Generator) -> float:
        """The entry speed [m/s], held up to the entry gate (then the kernel lets go)."""
        return self.entry_speed_mps

    def check_for_car(self, vehicle: Any) -> None:
        """``ValueError`` naming the car unless the entry speed is in its range (``feasibility.check_entry_speed``)."""
        from vtrack_gym.tracks.feasibility import check_entry_speed

        check_entry_speed(self.entry_speed_kmh, vehicle)


@dataclass(frozen=True)
class FollowProfile:
    """A ``tracks`` speed profile as a speed part: the PD-FLC follows its v_ref(s) at the car's station."""

    profile: Any
    follows_profile: ClassVar[bool] = True
    takes_entry_speed: ClassVar[bool] = False

    def tables(self, paths: tuple, vehicle: Any = None) -> tuple:
        """The profile's table per path."""
        from vtrack_gym.tracks.speed_profiles import speed_table

        return tuple(speed_table(p, self.profile) for p in paths)

    def release_columns(self, paths: tuple) -> np.ndarray:
        """The PD-FLC never lets go: (K, 2) of (+inf, 0)."""
        return _never_released(paths)

    def nominal_speed_mps(self, tables: tuple) -> float:
        """The profile's first row on the first path [m/s]."""
        return float(tables[0].v_mps[0])

    def start_speed_mps(self, peak_curvature_per_m: float, table: Any, rng: np.random.Generator) -> float:
        """The profile's speed at the start [m/s] (updated from the profile every step)."""
        return float(table.v_mps[0])

    def check_for_car(self, vehicle: Any) -> None:
        """The profile's lateral limit within the car's own (``speed_limits.check_profile_for_car``)."""
        from vtrack_gym.tracks.speed_limits import check_profile_for_car

        check_profile_for_car(self.profile, vehicle)


def bind_to_car(speed: Any, vehicle: Any, speed_loop_authority: float, at_rest: bool) -> Any:
    """``speed`` with its profile bound to the env's car: a profile with a ``for_car`` method (``EnvelopeLimited``
    with a ``throttle_authority``) limited by ``vehicle``'s powertrain at that authority (``SPEED_LOOP``: the
    PD-FLC's ``speed_loop_authority``, a throttle fraction) and, when the cars start ``at_rest``, starting from
    ``MIN_V_REF_MPS`` (a standing start) rather than at its lap speed; any other speed part unchanged."""
    from vtrack_gym.tracks.path import MIN_V_REF_MPS

    part = speed_part(speed)
    profile = getattr(part, "profile", None)
    if not callable(getattr(profile, "for_car", None)):
        return speed
    bound = profile.for_car(vehicle, speed_loop_authority, MIN_V_REF_MPS if at_rest else None)
    return speed if bound is profile else FollowProfile(bound)


CHECKED_PROFILES: tuple[str, ...] = ("ConstantSpeed", "FileSpeed", "SpeedRamp")
"""The package's profiles whose speeds an env checks against its car's powertrain (with any profile class of the
user's own); the profiles of limits (``CurvatureLimited``, ``EnvelopeLimited``) and the training mix are built to
their own acceleration figures."""


def check_tables_for_powertrain(speed: Any, bank: Any, vehicle: Any, authority: float) -> None:
    """A ``UserWarning`` per path when a followed profile (``CHECKED_PROFILES`` or a class from outside the
    package) asks for more forward acceleration or speed than ``vehicle`` gives at the speed loop's throttle
    ``authority`` (``powertrain_limits.check_table_for_powertrain``: the worst station and the figures)."""
    from vtrack_gym.tracks.powertrain_limits import check_table_for_powertrain

    part = speed_part(speed)
    profile = getattr(part, "profile", None)
    if not part.follows_profile or profile is None:
        return
    cls = type(profile)
    if cls.__module__.startswith("vtrack_gym.") and cls.__name__ not in CHECKED_PROFILES:
        return
    for path, table in zip(bank.paths, bank.speed_tables, strict=True):
        check_table_for_powertrain(table.v_mps, table.ds_m, vehicle, authority,
                                   f"the {cls.__name__} profile on {path.name!r} (followed by the speed loop)")


def _never_released(paths: tuple) -> np.ndarray:
    """(K, 2) release columns of a protocol whose PD-FLC never lets go: station +inf, mode 0."""
    out = np.zeros((len(paths), 2))
    out[:, 0] = np.inf
    return out


SPEED_PART_METHODS: tuple[str, ...] = ("tables", "release_columns", "nominal_speed_mps", "start_speed_mps",
                                       "check_for_car")
"""The speed-part protocol (with the class attributes ``follows_profile`` and ``takes_entry_speed``): what the
env asks of a scenario's speed part; ``HoldSpeed``, ``EntryThenRelease`` and ``FollowProfile`` implement it."""


def speed_part(speed: Any) -> Any:
    """``speed`` as a speed part: itself when it implements the protocol (``SPEED_PART_METHODS``), a ``tracks``
    speed profile (a ``row_speeds(path)`` method) wrapped in ``FollowProfile``; ``ValueError`` otherwise."""
    if all(callable(getattr(speed, m, None)) for m in SPEED_PART_METHODS):
        return speed
    if callable(getattr(speed, "row_speeds", None)):
        return FollowProfile(speed)
    raise ValueError("Scenario.speed must be a HoldSpeed, an EntryThenRelease, a tracks speed profile "
                     "(ConstantSpeed, CurvatureLimited, FileSpeed, ...) or a part with the speed-part methods "
                     f"({', '.join(SPEED_PART_METHODS)}) (got {type(speed).__name__})")


def is_profile(speed: Any) -> bool:
    """True when ``speed`` is followed along the path as a profile (``follows_profile``)."""
    return bool(speed_part(speed).follows_profile)


def check_speed(speed: Any) -> None:
    """``ValueError`` unless ``speed`` is a speed part or a tracks speed profile (``speed_part``)."""
    speed_part(speed)


def speed_tables(paths: tuple, speed: Any, vehicle: Any = None) -> tuple:
    """One ``tracks.SpeedTable`` per path (``speed_part(speed).tables``)."""
    return speed_part(speed).tables(paths, vehicle)


def release_columns(paths: tuple, speed: Any) -> np.ndarray:
    """Per path (K, 2): the station [m] from which the PD-FLC is off (+inf: never) and the pedal mode after it
    (``RELEASE_MODES``), the two track-metadata columns the compiled step reads."""
    return speed_part(speed).release_columns(paths)


def nominal_speed_mps(speed: Any, tables: tuple) -> float:
    """A representative reference speed [m/s]: the held one, the entry speed, or the profile's first row on the
    first path."""
    return speed_part(speed).nominal_speed_mps(tables)
