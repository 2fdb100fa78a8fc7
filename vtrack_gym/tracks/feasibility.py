"""Manoeuvres for a given car: its planned reference lines, speed profiles inside its own grip, its physical bounds.

Everything here judges feasibility with the car's own steady-state lateral limit (``vehicle.steady_state``: the
highest cornering equilibrium of the plant, which lies below mu g because of the Pacejka peak factors D < 1, the
tyres' load sensitivity under load transfer and the drive force), never with mu g.

- :func:`planned_maneuver`: a cone-lined manoeuvre (``GATED_MANEUVERS``) with the planned line for the car's body
  (``tracks.planned_line``; curvature rate bounded by the car's steering rate at the manoeuvre's speed), cached
  per car.
- :func:`envelope_profile`: an ``EnvelopeLimited`` speed profile checked against the car's lateral limit, its
  forward acceleration and top speed, optionally, the car's powertrain at a throttle authority.
- :func:`entry_speed_bound_kmh`: the highest entry speed at which the car, coasting from the entry gate (throttle
  released, the standard's ISO 3888-2 protocol) or holding its throttle (ISO 3888-1), can follow the planned line
  within its lateral limit.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from vtrack_gym.tracks.maneuvers import KMH_TO_MPS, MAX_ENTRY_SPEED_KMH, PLANNED_MARGIN_M, Maneuver, build_maneuver
from vtrack_gym.tracks.path import Path
from vtrack_gym.tracks.planned_line import BodyRectangle, curvature_rate_limit_per_m2
from vtrack_gym.tracks.speed_profiles import EnvelopeLimited
from vtrack_gym.vehicle.params import GRAVITY_MPS2, VehicleParams

GATED_MANEUVERS: tuple[str, ...] = ("iso3888_1", "iso3888_2", "slalom")
"""The manoeuvres with cone gates, which a planned line can be built for."""
BOUND_TOL_KMH = 0.01          # bisection tolerance of the entry-speed bound [km/h]
COAST_STEP_M = 0.05           # arc-length step of the coasting check [m]


def body_of(vehicle: VehicleParams) -> BodyRectangle:
    """The body rectangle of ``vehicle`` (length, width, CG to front end, its name)."""
    c = vehicle.chassis
    return BodyRectangle(c.body_length_m, c.body_width_m, c.cg_to_front_end_m, vehicle.name)


AFTER_ENTRY_PROTOCOLS: tuple[str, ...] = ("coast", "hold_throttle")
"""What the car does from the entry gate on when its entry-speed bound is computed (``envs.speed.AFTER_ENTRY``)."""


def check_width_for(name: str, vehicle: VehicleParams) -> None:
    """ValueError naming the field, the limit and the car when the body of ``vehicle`` is wider than manoeuvre
    ``name``'s lanes can be sized for (its parameters' ``vehicle_width_m`` range)."""
    from vtrack_gym._ranges import range_of
    from vtrack_gym.tracks.maneuvers import MANEUVERS

    rng = range_of(MANEUVERS[name][1], "vehicle_width_m")
    width = vehicle.chassis.body_width_m
    if rng.le is not None and width > float(rng.le):
        raise ValueError(f"ChassisParams.body_width_m = {width} m of {vehicle.name!r} is too wide for {name}: its "
                         f"cone lanes are sized for cars up to {float(rng.le):g} m wide")


def check_body_fits(path: Path, vehicle: VehicleParams) -> None:
    """ValueError naming the car, its width and the gate's limit if the body of ``vehicle`` is not narrower than
    every gate of ``path``."""
    width = vehicle.chassis.body_width_m
    for gate in path.gates:
        if width >= gate.width_m:
            raise ValueError(f"ChassisParams.body_width_m = {width} m of {vehicle.name!r} does not fit gate "
                             f"{gate.name or '?'!r} of {path.name!r}: the car must be narrower than the gate's "
                             f"{gate.width_m:.3f} m")


EXACT_GATED_MANEUVERS: tuple[str, ...] = ("iso3888_1", "iso3888_2")
"""The manoeuvres whose planned line has a second version (``tracks.exact_line``, ``planner_version=2``)."""


def curvature_rate_for(name: str, vehicle: VehicleParams) -> float:
    """The bound [1/m^2] on |dkappa/ds| of ``vehicle``'s planned line on manoeuvre ``name``: what its steering
    actuator follows at the manoeuvre's nominal speed (``planned_line.curvature_rate_limit_per_m2``)."""
    nominal = build_maneuver(name, vehicle_width_m=vehicle.chassis.body_width_m).spec.nominal_speed_mps
    return curvature_rate_limit_per_m2(vehicle.steering.max_road_wheel_rate_radps, vehicle.chassis.wheelbase_m,
                                       nominal)


@lru_cache(maxsize=64)
def planned_maneuver(name: str, vehicle: VehicleParams, margin_m: float = PLANNED_MARGIN_M,
                     planner_version: int = 1) -> Maneuver:
    """Manoeuvre ``name`` (one of ``GATED_MANEUVERS``) sized for ``vehicle``'s width, with the planned line for its
    body, ``margin_m`` [m] clear of every cone line (default: the least-curvature line, 1 cm clear); |dkappa/ds| is
    bounded by what its steering actuator follows at the manoeuvre's nominal speed
    (``planned_line.curvature_rate_limit_per_m2``). ``planner_version`` 2 (``EXACT_GATED_MANEUVERS``): the line of
    ``tracks.exact_line`` (unique, the body judged exactly; ``Maneuver.line`` gives its exact curvature). Cached
    per (name, car, margin, version)."""
    if planner_version == 2 and name not in EXACT_GATED_MANEUVERS:
        raise ValueError(f"planner_version 2 applies to {', '.join(EXACT_GATED_MANEUVERS)} (got {name!r})")
    if name not in GATED_MANEUVERS:
        raise ValueError(f"no planned line for {name!r}: it has no cone gates (gated: {', '.join(GATED_MANEUVERS)})")
    check_width_for(name, vehicle)
    rate = curvature_rate_for(name, vehicle)
    version = {} if planner_version == 1 else {"planner_version": planner_version}
    maneuver = build_maneuver(name, vehicle_width_m=vehicle.chassis.body_width_m, reference="planned",
                              body=body_of(vehicle), max_curvature_rate_per_m2=rate, planned_margin_m=margin_m,
                              **version)
    check_body_fits(maneuver.path, vehicle)
    return maneuver


def envelope_profile(vehicle: VehicleParams, max_speed_mps: float, max_lateral_accel_mps2: float,
                     max_accel_mps2: float | None = 2.0, max_decel_mps2: float = 3.0, *,
                     throttle_authority: float | None = None, start_speed_mps: float | None = None
                     ) -> EnvelopeLimited:
    """An ``EnvelopeLimited`` profile for ``vehicle``: refused (ValueError) if ``max_lateral_accel_mps2`` exceeds the
    car's least steady-state lateral limit up to ``max_speed_mps``, a warning above 90 % of it.

    ``throttle_authority`` (a throttle fraction in (0, 1]): the profile speeds up at most as the car's powertrain
    allows at that throttle (drive force less drag and rolling resistance, ``vehicle.longitudinal``) and is capped
    at the car's top speed there (a warning names it); 1.0 for an agent that drives the throttle itself, the
    speed loop's ``envs.pdflc.speed_loop_throttle_authority`` (0.348) for the PD-FLC. ``max_accel_mps2`` then is
    an extra cap (None: the powertrain alone). ``start_speed_mps`` [m/s]: start from that speed at s = 0 (None: a
    flying lap). None (default): the fixed ``max_accel_mps2`` of earlier versions."""
    from vtrack_gym.vehicle.steady_state import lowest_lateral_limit_mps2

    bound = {} if throttle_authority is None else {"throttle_authority": throttle_authority, "vehicle": vehicle}
    return EnvelopeLimited(max_speed_mps, max_lateral_accel_mps2, max_accel_mps2, max_decel_mps2,
                           vehicle_limit_mps2=lowest_lateral_limit_mps2(vehicle, max_speed_mps),
                           vehicle_name=vehicle.name, start_speed_mps=start_speed_mps, **bound)


@dataclass(frozen=True)
class CoastCheck:
    """A coasting run along a line: ``entry_speed_mps`` [m/s] at the entry gate, the worst ``usage`` [-] (v^2 |kappa|
    over the car's lateral limit at v; <= 1 is feasible) at ``worst_s_m`` [m], where the speed is
    ``worst_speed_mps`` [m/s]."""

    entry_speed_mps: float
    usage: float
    worst_s_m: float
    worst_speed_mps: float


def coast_speed_mps(vehicle: VehicleParams, entry_speed_mps: float, distance_m: np.ndarray) -> np.ndarray:
    """Speed [m/s] after coasting ``distance_m`` [m] on a level road from ``entry_speed_mps`` [m/s]: drag and rolling
    resistance only, d(v^2)/ds = -(rho C_d A / m) v^2 - 2 C_rr g (exact solution; CHOICE: the tyres' cornering drag
    is left out, so the car keeps more speed than it would, and the bound is a little conservative)."""
    m = vehicle.chassis.mass_kg
    a = vehicle.powertrain.air_density_kgpm3 * vehicle.powertrain.drag_area_m2 / m
    b = 2.0 * vehicle.tyres.rolling_resistance_coeff * GRAVITY_MPS2
    d = np.asarray(distance_m, dtype=float)
    if a == 0.0:
        u = entry_speed_mps ** 2 - b * d
    else:
        u = (entry_speed_mps ** 2 + b / a) * np.exp(-a * d) - b / a
    return np.sqrt(np.maximum(u, 0.0))


def released_speed_mps(vehicle: VehicleParams, entry_speed_mps: float, distance_m: np.ndarray,
                       after_entry: str = "coast") -> np.ndarray:
    """Speed [m/s] ``distance_m`` [m] past the entry gate under ``after_entry`` (``AFTER_ENTRY_PROTOCOLS``):
    :func:`coast_speed_mps`, or for ``"hold_throttle"`` the entry speed (APPROXIMATION: the throttle that held the
    entry speed on the level approach balances drag and rolling resistance there, so on the line the car keeps the
    entry speed; the tyres' cornering drag, left out, would slow it, so the car is credited with at least its true
    speed and the bound is conservative)."""
    if after_entry not in AFTER_ENTRY_PROTOCOLS:
        raise ValueError(f"after_entry must be one of {', '.join(AFTER_ENTRY_PROTOCOLS)} (got {after_entry!r})")
    if after_entry == "coast":
        return coast_speed_mps(vehicle, entry_speed_mps, distance_m)
    return np.full(np.shape(distance_m), float(entry_speed_mps))


def coast_check(path: Path, vehicle: VehicleParams, entry_speed_mps: float, after_entry: str = "coast",
                kappa_at: Callable[[np.ndarray], np.ndarray] | None = None) -> CoastCheck:
    """Drive ``path`` from its first gate's start to its last gate's end from ``entry_speed_mps`` [m/s] under
    ``after_entry`` (:func:`released_speed_mps`) and compare v^2 |kappa| with the car's lateral limit at v
    (``steady_state.lateral_limit_mps2``). ``kappa_at``: the line's exact curvature [1/m] at arc lengths [m]
    (``exact_line.ExactLine.kappa_at``; None: the path's interpolation, ``Path.sample``)."""
    from vtrack_gym.vehicle.steady_state import lateral_limit_mps2

    if not path.gates:
        raise ValueError(f"path {path.name!r} has no gates: no entry gate to coast from")
    s0, s1 = path.gates[0].s_start_m, max(g.s_end_m for g in path.gates)
    s = np.linspace(s0, s1, max(2, math.ceil((s1 - s0) / COAST_STEP_M) + 1))
    v = released_speed_mps(vehicle, entry_speed_mps, s - s0, after_entry)
    kappa = path.sample(s).kappa if kappa_at is None else kappa_at(s)
    usage = v * v * np.abs(kappa) / np.asarray(lateral_limit_mps2(vehicle, v))
    k = int(np.argmax(usage))
    return CoastCheck(float(entry_speed_mps), float(usage[k]), float(s[k]), float(v[k]))


def check_entry_speed(entry_speed_kmh: float, vehicle: VehicleParams) -> None:
    """ValueError naming the field, the limit and the car when ``entry_speed_kmh`` is not in (0, 200] km/h."""
    if not (math.isfinite(entry_speed_kmh) and 0.0 < entry_speed_kmh <= MAX_ENTRY_SPEED_KMH):
        raise ValueError(f"entry_speed_kmh must be in (0, {MAX_ENTRY_SPEED_KMH:g}] km/h (got {entry_speed_kmh} "
                         f"for {vehicle.name!r})")


def entry_speed_bound_kmh(vehicle: VehicleParams, maneuver: str = "iso3888_2", after_entry: str = "coast",
                          margin_m: float | None = None, planner_version: int = 1) -> float:
    """The car's physical entry-speed bound [km/h] on a cone-lined manoeuvre: the highest entry speed at which,
    from the entry gate on along the planned line for its body (:func:`planned_maneuver`), coasting
    (``after_entry="coast"``, ISO 3888-2) or holding its throttle (``"hold_throttle"``, ISO 3888-1; see
    :func:`released_speed_mps` for the approximation), it never needs more than its own steady-state lateral limit
    (bisection to ``BOUND_TOL_KMH``, within (0, 200] km/h). A policy passing above it has cut through the
    physics, not driven better. ``margin_m`` [m]: the line's clearance from the cone lines (default: the
    least-curvature line, the physical bound: 1 cm for ``planner_version`` 1, 0 for 2, whose line's curvature is
    the spline's own, exact; a line with a tracking margin, as the envs drive, has a lower one)."""
    if margin_m is None:
        margin_m = PLANNED_MARGIN_M if planner_version == 1 else 0.0
    m = planned_maneuver(maneuver, vehicle, margin_m, planner_version)
    path, exact = m.path, (None if m.line is None else m.line.kappa_at)

    def usage(kmh: float) -> float:
        return coast_check(path, vehicle, kmh * KMH_TO_MPS, after_entry, exact).usage

    lo, hi = 1.0, MAX_ENTRY_SPEED_KMH
    if usage(lo) > 1.0:
        raise ValueError(f"{vehicle.name!r} cannot follow the planned {maneuver} line even at {lo:g} km/h")
    if usage(hi) <= 1.0:
        return hi
    while hi - lo > BOUND_TOL_KMH:
        mid = 0.5 * (lo + hi)
        if usage(mid) <= 1.0:
            lo = mid
        else:
            hi = mid
    return lo


__all__ = ["AFTER_ENTRY_PROTOCOLS", "EXACT_GATED_MANEUVERS", "GATED_MANEUVERS", "CoastCheck", "body_of",
           "check_body_fits", "check_entry_speed", "check_width_for", "coast_check", "coast_speed_mps",
           "curvature_rate_for", "entry_speed_bound_kmh", "envelope_profile", "planned_maneuver",
           "released_speed_mps"]
