"""The speed protocol of a scenario (a scenario part): hold a set speed, or follow a speed profile along the path.

A scenario's ``speed`` is a ``HoldSpeed`` (the paper's scenarios: the PD-FLC holds one reference speed, optionally
drawn per episode) or any ``tracks`` speed profile (``ConstantSpeed``, ``CurvatureLimited``, ``FileSpeed``, the
training mix's), whose v_ref(s) the PD-FLC follows at the car's station.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from vtrack_gym._ranges import documented, ranged, validate
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

    def set_speed_mps(self, peak_curvature_per_m: float, rng: np.random.Generator) -> float:
        """The episode's set speed [m/s] on a track of this peak |curvature| [1/m]."""
        if self.random_range_mps is None:
            return self.target_speed_mps
        lo, hi = self.random_range_mps
        if peak_curvature_per_m > 0.0:
            hi = max(lo, min(hi, float(np.sqrt(FEASIBLE_LATERAL_ACC_MPS2 / peak_curvature_per_m))))
        return float(rng.uniform(lo, hi))


def is_profile(speed: Any) -> bool:
    """True when ``speed`` is a speed profile followed along the path (not a ``HoldSpeed``)."""
    return not isinstance(speed, HoldSpeed)


def check_speed(speed: Any) -> None:
    """``ValueError`` unless ``speed`` is a ``HoldSpeed`` or a tracks speed profile."""
    from vtrack_gym.tracks.speed_profiles import SpeedProfile

    if not isinstance(speed, (HoldSpeed, SpeedProfile)):
        raise ValueError("Scenario.speed must be a HoldSpeed or a tracks speed profile (ConstantSpeed, "
                         f"CurvatureLimited, FileSpeed) (got {type(speed).__name__})")


def speed_tables(paths: tuple, speed: Any) -> tuple:
    """One ``tracks.SpeedTable`` per path: the profile, or the held speed everywhere."""
    from vtrack_gym.tracks.speed_profiles import ConstantSpeed, speed_table

    profile = ConstantSpeed(speed.target_speed_mps) if isinstance(speed, HoldSpeed) else speed
    return tuple(speed_table(p, profile) for p in paths)


def nominal_speed_mps(speed: Any, tables: tuple) -> float:
    """A representative reference speed [m/s]: the held one, or the profile's first row on the first path."""
    return speed.target_speed_mps if isinstance(speed, HoldSpeed) else float(tables[0].v_mps[0])
