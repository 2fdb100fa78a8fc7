"""Leaderboard suites: which (env, seed, reset options) episodes a policy is scored on.

``paper``: the paper's two nominal scenarios, one episode each (seed 0).
``robust``: both scenarios under randomised friction, mass, target speed, sensor noise and actuator delay,
drawn deterministically from a fixed list of seeds (the same perturbations for every policy and release).
The friction range of each scenario keeps the course physically drivable: the handling course's 20 m
hairpin needs ~0.63 g at 40 km/h (mu drawn in 0.75-1.0) and the lane change ~0.81 g at 120 km/h (mu drawn
in 0.9-1.1); below that every policy must fail, which would measure the road, not the controller.
``maneuvers``: the standard manoeuvres at their current versions (``vtrack/ISO3888-1-v1``, ``ISO3888-2-v1``,
``ISO4138-Circle-v0``, ``Slalom-v1``, ``StepCurvature-v0``; ``envs.scenarios.MANEUVER_IDS``), each with its own
speed protocol (the ISO 3888 ids: entry speed, then the throttle held or released), seed 0 (deterministic without
noise), judged by its own success criterion.
``highway``: highway-env's ``lane-keeping-v0`` through ``vtrack_gym.interop`` (three starts; needs the
``highway`` extra).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vtrack_gym.envs.config import DLC120, LATERAL_TRACKING
from vtrack_gym.envs.scenarios import MANEUVER_SCENARIOS

ROBUST_SEEDS: tuple[int, ...] = (101, 202, 303, 404, 505)


@dataclass(frozen=True)
class Episode:
    """One scored episode of a suite: reset with ``seed`` and ``options``, on the env made with ``vehicle`` (a name
    of ``vehicle.list_vehicles()``, a vehicle file path or a ``vehicle.catalog.VehicleFile`` read once; ``None``:
    the default car)."""

    env_id: str
    seed: int
    options: dict[str, Any] = field(default_factory=dict)
    vehicle: Any = None

    @property
    def make_kwargs(self) -> dict[str, Any]:
        """Keyword arguments of ``gym.make`` for this episode (the vehicle, if one is chosen)."""
        return {} if self.vehicle is None else {"vehicle": self.vehicle}


def with_vehicle(episodes: Sequence[Episode], vehicle: Any) -> list[Episode]:
    """``episodes`` driven with ``vehicle`` (a name, a path, a ``vehicle.catalog.VehicleFile``; ``None``:
    unchanged)."""
    from dataclasses import replace

    if vehicle is None:
        return list(episodes)
    from vtrack_gym.vehicle.catalog import VehicleFile

    chosen = vehicle if isinstance(vehicle, VehicleFile) else str(vehicle)   # a file read once stays as read
    return [replace(ep, vehicle=chosen) for ep in episodes]


MANEUVER_ENV_IDS: tuple[str, ...] = tuple(sc.env_id for sc in MANEUVER_SCENARIOS)
"""Env ids of the ``maneuvers`` suite, in library order."""


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


def suite_episodes(name: str, quick: bool = False, seeds: Sequence[int] | None = None) -> list[Episode]:
    """The episodes of suite ``name`` (``quick`` keeps one robust seed, for smoke tests).

    ``seeds`` replaces the suite's seeds (paper, maneuvers: every scenario at each seed; robust: the perturbations
    drawn from each seed; highway: seeds 0-2 only, one initial condition each).
    """
    if name == "paper":
        return [Episode(env_id, s) for s in (seeds or (0,)) for env_id in ("LateralTracking-v0", "DLC120-v0")]
    if name == "robust":
        chosen = tuple(seeds) if seeds else (ROBUST_SEEDS[:1] if quick else ROBUST_SEEDS)
        return [Episode(sc.name, s, robust_options(s, sc.speed.target_speed_mps, ROBUST_FRICTION[sc.name]))
                for sc in (LATERAL_TRACKING, DLC120) for s in chosen]
    if name == "maneuvers":
        return [Episode(env_id, s) for s in (seeds or (0,)) for env_id in MANEUVER_ENV_IDS]
    if name == "highway":
        return highway_episodes(quick=quick, seeds=seeds)
    raise ValueError(f"unknown suite {name!r}; valid: {', '.join(SUITES)}")


HIGHWAY_SEEDS: tuple[int, ...] = (0, 1, 2)
"""Seeds of the ``highway`` leaderboard suite (one initial condition each, see ``highway_episodes``)."""

HIGHWAY_STARTS: dict[int, dict[str, float]] = {
    0: {"initial_lateral_offset_m": -4.0},  # highway-env's own offset (4 m to the right), lane start
    1: {"initial_lateral_offset_m": 4.0, "start_station_m": 25.0},  # mirrored, a quarter period further
    2: {"initial_lateral_offset_m": 0.0, "initial_heading_error_rad": 0.2, "start_station_m": 50.0},
}
"""Reset options of the ``highway`` suite's episodes, by seed."""


def highway_episodes(quick: bool = False, seeds: Sequence[int] | None = None) -> list[Episode]:
    """Episodes of the ``highway`` leaderboard suite: the adapter from three initial conditions (seed -> options).

    Seed 0 is highway-env's own initial offset (4 m right of the sine lane's centre line at its start); seed 1
    the mirrored offset a quarter period further; seed 2 on the centre line with a 0.2 rad heading error. Every
    episode drives to the end of the sine lane (~500 m at 8.3 m/s). ``quick`` keeps seed 0 only.
    """
    from vtrack_gym.interop import HIGHWAY_ENV_ID, register_highway_envs

    register_highway_envs()
    if seeds and not set(seeds) <= set(HIGHWAY_STARTS):
        raise ValueError(f"highway suite seeds must be among {sorted(HIGHWAY_STARTS)} (got {list(seeds)})")
    chosen = tuple(seeds) if seeds else (HIGHWAY_SEEDS[:1] if quick else HIGHWAY_SEEDS)
    return [Episode(HIGHWAY_ENV_ID, s, dict(HIGHWAY_STARTS[s])) for s in chosen]


SUITES: tuple[str, ...] = ("paper", "robust", "highway", "maneuvers")

PRIMARY_METRICS: dict[str, str] = {"paper": "max_e_y_m", "robust": "max_e_y_m", "highway": "itae",
                                   "maneuvers": "max_e_y_m"}
"""The metric each suite ranks on after the success rate (lower is better; over successful episodes only).

paper/robust/maneuvers: the largest lateral error |e_y| [m], the worst case that decides whether the car stays in
its lane or clears the cones, independent of the course length and of when the error occurs. highway: ITAE [m s^2],
because every policy starts 4 m off the lane centre there, so the maximum is the initial offset for all of them;
ITAE weights the error by time and measures how fast and how well the offset is removed. Other suites (custom,
tuning) rank on ``max_e_y_m``."""


def primary_metric(suite: str) -> str:
    """The metric ``suite``'s leaderboard ranks on after the success rate (see ``PRIMARY_METRICS``; a label of a
    non-standard seed set, ``robust[seeds=7]``, ranks like its suite)."""
    return PRIMARY_METRICS.get(base_suite(suite), "max_e_y_m")


STANDARD_SEEDS: dict[str, tuple[int, ...]] = {"paper": (0,), "robust": ROBUST_SEEDS, "highway": HIGHWAY_SEEDS,
                                              "maneuvers": (0,)}
"""The seeds of each suite's standard episodes (what its leaderboard ranks)."""
QUICK_SUITES: frozenset[str] = frozenset({"robust", "highway"})
"""Suites whose ``quick`` variant drops seeds."""


def base_suite(label: str) -> str:
    """The suite a stored suite label belongs to: ``robust`` for ``robust``, ``robust[seeds=7]``, ``robust[quick]``."""
    return label.partition("[")[0]


def _seed_text(seeds: Sequence[int]) -> str:
    """``0-4,7``: sorted seeds with runs of consecutive ones as ranges."""
    ordered = sorted(set(int(s) for s in seeds))
    parts: list[str] = []
    start = prev = ordered[0]
    for s in [*ordered[1:], None]:
        if s is not None and s == prev + 1:
            prev = s
            continue
        parts.append(str(start) if start == prev else f"{start}-{prev}")
        if s is not None:
            start = prev = s
    return ",".join(parts)


def suite_label(name: str, quick: bool = False, seeds: Sequence[int] | None = None) -> str:
    """The suite name rows of ``suite_episodes(name, quick, seeds)`` are stored under: ``name`` for the standard
    episodes, else ``name[seeds=...]`` (another seed set; ``seeds`` wins over ``quick``) or ``name[quick]``, so a
    subset or another set of seeds is never ranked with the suite's standard board."""
    standard = STANDARD_SEEDS.get(name)
    if seeds:
        if standard is not None and sorted(set(int(s) for s in seeds)) == sorted(standard):
            return name
        return f"{name}[seeds={_seed_text(seeds)}]"
    if quick and name in QUICK_SUITES:
        return f"{name}[quick]"
    return name
