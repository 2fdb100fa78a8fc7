"""Standard manoeuvres as data: each a reference :class:`Path` (cone gates where the test has cones) plus a frozen
:class:`ManeuverSpec` (standard, nominal speed, speed profile, time limit, success criterion).

Build one with its builder and a parameter object (every parameter validated, units in the names), or by name::

    m = iso3888_2_obstacle_avoidance(ObstacleAvoidanceParams(vehicle_width_m=1.9))
    m = build_maneuver("iso3888_2", vehicle_width_m=1.9)          # same thing
    m.path, m.spec.speed_profile, m.spec.success_criterion

=====================  =========================================  =========  ====================================
name                   test                                       speed      key geometry (w = vehicle width)
=====================  =========================================  =========  ====================================
``iso3888_1``          ISO 3888-1 double lane change              80 km/h    lanes 15 / 25 / 15 m, gaps 30 / 25 m
``iso3888_2``          ISO 3888-2 obstacle avoidance ("moose")    80 km/h    lanes 12 / 11 / 12 m, gaps 13.5 / 12.5
``iso4138_circle``     ISO 4138 steady-state circle, speed ramp   ramp       R = 40 m, 0.2 m/s^2 up to 1.1 v_grip
``slalom``             slalom (no standard: CHOICE)               40 km/h    10 cones, 18 m apart
``step_curvature``     straight into a constant radius            54 km/h    60 m straight, R = 50 m, 180 deg
=====================  =========================================  =========  ====================================

Success criteria (``ManeuverSpec.success_criterion``, one of ``SUCCESS_CRITERIA``): ``gates`` (the end reached, no
gate left by the body: the ISO 3888 pass/fail), ``circle`` (|e_y| within ``lateral_tolerance_m`` until the reference
speed reaches the grip-limit speed sqrt(mu g R); the peak lateral acceleration reported), ``end`` (the end reached
on the road; the e_y overshoot after the curvature step reported).

Reference lines (``reference``, see ``REFERENCES``). ``"lane_centres"`` (the default; ``tracks.lanes``): straight
at the lane centres, C^2 curvature pulses between lanes, reaching ``overlap_m`` into the lanes (7 m for ISO 3888-1,
5 m for ISO 3888-2; a line straight in the whole of every gate needs at least 4 v^2 dy / dx^2: 1.07 g and 4.3 g at
80 km/h), gates anchored at the cones' fixed positions (``Gate.anchor``): peak v^2 kappa 0.59 g (ISO 3888-1) and
1.75 g (ISO 3888-2) at 80 km/h. ``"planned"``: the line of least peak curvature along which the car's body
(``body``, a ``BodyRectangle``) passes every gate with a bounded curvature rate (``max_curvature_rate_per_m2``),
by ``planner_version`` 1 (``tracks.planned_line``: linear programmes, the body sampled) or 2
(``tracks.exact_line``: one optimum, the body judged exactly, exact curvature); ``tracks.feasibility`` builds it
per car, the rate bounded by the car's steering. The body of a car of the gates' width, driven exactly on either
line, hits no gate (tested).

Feasibility is judged against the car's own steady-state lateral limit (``vehicle.steady_state``: about 0.80 g
for the paper car at 80 km/h), not mu g: the plant's tyres peak below mu F_z and lose grip under load transfer.
ISO 3888-2 held at a constant 80 km/h asks 1.13 g on the best line, so no car of this width passes it at that
speed; the standard's protocol (enter at the test speed, release the throttle at the entry gate) has a physical
entry-speed bound (``feasibility.entry_speed_bound_kmh``).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vtrack_gym._ranges import documented, ranged, validate
from vtrack_gym.tracks.dlc import LANE_WIDTH_ADD_M, LANE_WIDTH_FACTORS, DoubleLaneChangeSpec, build_double_lane_change
from vtrack_gym.tracks.lanes import LaneSection, lane_sequence_path, pulse_segments, transition
from vtrack_gym.tracks.path import DEFAULT_DS_M, Gate, Path
from vtrack_gym.tracks.planned_line import BodyRectangle, plan_line
from vtrack_gym.tracks.profiles import CurvatureProfile
from vtrack_gym.tracks.speed_profiles import ConstantSpeed, SpeedProfile, SpeedRamp
from vtrack_gym.tracks.table import COL_KAPPA

VERSION = "1"
KMH_TO_MPS = 1.0 / 3.6
GRAVITY_MPS2 = 9.81                      # same value as vehicle.params.GRAVITY_MPS2 (tracks does not import vehicle)
PAPER_CAR_WIDTH_M = 1.916                # the paper's car (IDSC body width), reference-data section 1
PAPER_CAR_LENGTH_M = 4.75                # ... its body length and CG to front end (IDSC)
PAPER_CAR_CG_TO_FRONT_M = 1.915

REFERENCES: dict[str, str] = {"lane_centres": "straight at the lane centres, C^2 curvature pulses between lanes",
                              "planned": "the line of least peak curvature along which the car's body passes "
                                         "every gate, for the body given as the parameters' ``body``"}
"""Reference lines a cone-lined manoeuvre can be built with (its parameters' ``reference``)."""
LANE_OFFSET_READINGS: dict[str, str] = {
    "lane_centre": "lane 3's centre line lane_offset_m left of lane 1's (the paper's '3.5 m between the lanes')",
    "cone_line": "lane 3's right cone line lane_offset_m left of lane 1's centre line (Chrono's ISO3888_Helper)"}
"""Readings of ISO 3888-1's lateral offset of lane 3 (``DoubleLaneChangeParams.lane_offset_from``)."""
DEFAULT_LANE_OFFSET_FROM: dict[str, str] = {"planned": "cone_line", "lane_centres": "lane_centre"}
"""ISO 3888-1's lane-offset reading when none is given, per reference line: the cone-based planned line (the
standard as its cones pose it) reads ``cone_line``; the lane-centre line keeps the paper's ``lane_centre``."""
PLANNED_MARGIN_M = 0.01                  # least clearance [m] between the body and a cone line on a planned line
TIME_FACTOR = 1.25                       # CHOICE: time limit = TIME_FACTOR x nominal travel time + TIME_MARGIN_S
TIME_MARGIN_S = 5.0

SUCCESS_CRITERIA: dict[str, str] = {
    "gates": "reaches the end of the path with gate_violations == 0 (ISO 3888 pass/fail)",
    "circle": "|e_y| <= lateral_tolerance_m while the reference speed is below grip_limit_speed_mps "
                       "(until the ramp ends or the grip limit is reached); report the peak lateral acceleration",
    "end": "reaches the end of the path without leaving the road; report the e_y overshoot after the step",
}
"""Documented success criteria, name -> meaning (see the module docstring). The names are those of the envs'
criterion classes (``envs.criteria.CRITERIA``: ``ConeGates``, ``CircleAtLimit``, ``EndReached``), one vocabulary."""


def grip_limit_speed_mps(friction_mu: float, radius_m: float, gravity_mps2: float = GRAVITY_MPS2) -> float:
    """Analytic grip-limit speed on a circle of radius ``radius_m`` [m] for friction ``friction_mu`` [-]:
    v = sqrt(mu g R) [m/s] (point mass, flat road, lateral force only)."""
    if not (math.isfinite(friction_mu) and 0.0 < friction_mu <= 3.0):
        raise ValueError(f"friction_mu must be in (0, 3] (got {friction_mu})")
    if not (math.isfinite(radius_m) and radius_m > 0.0):
        raise ValueError(f"radius_m must be > 0 m (got {radius_m})")
    if not (math.isfinite(gravity_mps2) and gravity_mps2 > 0.0):
        raise ValueError(f"gravity_mps2 must be > 0 m/s^2 (got {gravity_mps2})")
    return math.sqrt(friction_mu * gravity_mps2 * radius_m)


@dataclass(frozen=True)
class ManeuverSpec:
    """A manoeuvre as data: ``name``, the ``standard`` it follows (or "none (CHOICE)"), its ``nominal_speed_mps``
    [m/s] (the standard's test speed, or the ramp's end speed for the circle), the ``speed_profile`` to drive
    (a tracks speed profile), ``time_limit_s`` [s], ``success_criterion`` (a key of ``SUCCESS_CRITERIA``),
    ``source`` (where the numbers come from), ``lateral_tolerance_m`` [m] and ``grip_limit_speed_mps`` [m/s] for
    ``circle`` (None otherwise), and ``vehicle_width_m`` [m], the width the gates were sized for."""

    name: str
    standard: str
    nominal_speed_mps: float
    speed_profile: SpeedProfile = field(repr=False)
    time_limit_s: float
    success_criterion: str
    source: str
    vehicle_width_m: float
    lateral_tolerance_m: float | None = None
    grip_limit_speed_mps: float | None = None

    def __post_init__(self) -> None:
        if self.success_criterion not in SUCCESS_CRITERIA:
            raise ValueError(f"ManeuverSpec.success_criterion must be one of {sorted(SUCCESS_CRITERIA)} "
                             f"(got {self.success_criterion!r})")
        for name in ("nominal_speed_mps", "time_limit_s", "vehicle_width_m"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0.0):
                raise ValueError(f"ManeuverSpec.{name} must be a finite number > 0 (got {value!r})")
        if not isinstance(self.speed_profile, SpeedProfile):
            raise ValueError(f"ManeuverSpec.speed_profile must be a tracks speed profile "
                             f"(got {type(self.speed_profile).__name__})")
        circle = self.success_criterion == "circle"
        for name in ("lateral_tolerance_m", "grip_limit_speed_mps"):
            value = getattr(self, name)
            if circle and not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0.0):
                raise ValueError(f"ManeuverSpec.{name} must be > 0 for 'circle' (got {value!r})")


@dataclass(frozen=True, eq=False)
class Maneuver:
    """A built manoeuvre: the reference ``path`` and its ``spec``."""

    path: Path
    spec: ManeuverSpec
    line: Any = None          # a version-2 planned line's ``exact_line.ExactLine`` (exact curvature), else None

    @property
    def peak_lateral_accel_mps2(self) -> float:
        """v_nominal^2 max|kappa| of the reference line [m/s^2]: what exact tracking at the nominal speed asks for."""
        return float(self.spec.nominal_speed_mps ** 2 * np.max(np.abs(self.path.table[:, COL_KAPPA])))


def _time_limit_s(length_m: float, speed_mps: float) -> float:
    return float(math.ceil(TIME_FACTOR * length_m / speed_mps + TIME_MARGIN_S))


def _at_constant_speed(path: Path | tuple[Path, Any], name: str, standard: str, speed_mps: float, criterion: str,
                       vehicle_width_m: float, source: str) -> Maneuver:
    """A manoeuvre driven at one speed [m/s] (time limit from the path length); ``path`` may be (path, line)."""
    path, line = path if isinstance(path, tuple) else (path, None)
    return Maneuver(path, ManeuverSpec(
        name=name, standard=standard, nominal_speed_mps=speed_mps, speed_profile=ConstantSpeed(speed_mps),
        time_limit_s=_time_limit_s(path.length_m, speed_mps), success_criterion=criterion,
        vehicle_width_m=vehicle_width_m, source=source), line)


def _check_reference(params: Any) -> None:
    """The reference-line fields of a cone-lined manoeuvre's parameters: ``reference`` a key of ``REFERENCES``,
    ``body`` None or a ``BodyRectangle`` of the parameters' ``vehicle_width_m``."""
    name = type(params).__name__
    if params.reference not in REFERENCES:
        raise ValueError(f"{name}.reference must be one of {sorted(REFERENCES)} (got {params.reference!r})")
    body = params.body
    if body is not None and not isinstance(body, BodyRectangle):
        raise ValueError(f"{name}.body must be a BodyRectangle or None (got {type(body).__name__})")
    if body is not None and body.width_m != params.vehicle_width_m:
        raise ValueError(f"{name}.body.width_m ({body.width_m} m, {body.name!r}) must equal vehicle_width_m "
                         f"({params.vehicle_width_m} m): the lanes are sized for the car that drives them")


def _body(params: Any) -> BodyRectangle:
    """The body a planned line is planned for: ``params.body``, else the paper car's length at this width."""
    if params.body is not None:
        return params.body
    return BodyRectangle(PAPER_CAR_LENGTH_M, params.vehicle_width_m, PAPER_CAR_CG_TO_FRONT_M, "paper car")


def _planned_path(params: Any, lanes: tuple[LaneSection, ...], gaps_m: tuple[float, ...], *, approach_m: float,
                  run_out_m: float, half_width_m: float, ds_m: float, name: str) -> Path | tuple[Path, Any]:
    """The planned line's path (``planner_version`` 1: ``plan_line``), or (path, ``ExactLine``) (version 2)."""
    body = _body(params)
    if params.planned_margin_m != PLANNED_MARGIN_M:
        name = f"{name}_m{params.planned_margin_m:g}"
    if getattr(params, "planner_version", 1) == 2:
        from vtrack_gym.tracks.exact_line import plan_exact_line

        exact = plan_exact_line(lanes, gaps_m, body, approach_m=approach_m, run_out_m=run_out_m, ds_m=ds_m,
                                max_curvature_rate_per_m2=params.max_curvature_rate_per_m2, version="2",
                                margin_m=params.planned_margin_m, half_width_m=half_width_m, name=f"{name}_exact")
        return exact.path, exact
    line = plan_line(lanes, gaps_m, body, approach_m=approach_m, run_out_m=run_out_m,
                     max_curvature_rate_per_m2=params.max_curvature_rate_per_m2, margin_m=params.planned_margin_m,
                     half_width_m=half_width_m, ds_m=ds_m, name=f"{name}_planned_l{body.length_m:g}", version=VERSION)
    return line.path


# ------------------------------------------------------------------------------------------------ ISO 3888-1
@documented
@dataclass(frozen=True)
class DoubleLaneChangeParams:
    """ISO 3888-1 double lane change at its native lengths (see :func:`iso3888_1_double_lane_change`)."""

    vehicle_width_m: float = ranged(PAPER_CAR_WIDTH_M, gt=0.5, le=4.0, unit="m")
    speed_mps: float = ranged(80.0 * KMH_TO_MPS, gt=0.0, le=100.0, unit="m/s")   # nominal test speed 80 km/h
    approach_m: float = ranged(100.0, ge=0.0, le=10000.0, unit="m")
    overlap_m: float = ranged(7.0, ge=0.0, le=7.5, unit="m")       # CHOICE: transitions reach 7 m into the lanes
    # ISO's 3.5 m, measured as ``lane_offset_from`` says (a key of LANE_OFFSET_READINGS; None: the reference
    # line's default, ``DEFAULT_LANE_OFFSET_FROM``)
    lane_offset_m: float = ranged(3.5, gt=0.5, le=20.0, unit="m")
    lane_offset_from: str | None = None
    reference: str = "lane_centres"                                 # a key of REFERENCES
    body: BodyRectangle | None = None                               # the car a planned line is for
    max_curvature_rate_per_m2: float | None = ranged(None, gt=0.0, le=10.0, unit="1/m^2")   # planned line only
    planned_margin_m: float = ranged(PLANNED_MARGIN_M, ge=0.0, le=0.5, unit="m")            # planned line only
    planner_version: int = ranged(1, ge=1, le=2, integer=True)      # 1: planned_line, 2: exact_line (unique, exact)

    def __post_init__(self) -> None:
        validate(self)
        _check_reference(self)
        if self.lane_offset_from is None:
            object.__setattr__(self, "lane_offset_from", DEFAULT_LANE_OFFSET_FROM[self.reference])
        if self.lane_offset_from not in LANE_OFFSET_READINGS:
            raise ValueError(f"DoubleLaneChangeParams.lane_offset_from must be one of {sorted(LANE_OFFSET_READINGS)} "
                             f"(got {self.lane_offset_from!r})")

    def lane3_centre_offset_m(self) -> float:
        """Lane 3's centre left of lane 1's [m]: ``lane_offset_m`` (reading ``lane_centre``) or ``lane_offset_m``
        plus half of lane 3's width 1.2 w + 0.25 (reading ``cone_line``)."""
        if self.lane_offset_from == "lane_centre":
            return self.lane_offset_m
        return self.lane_offset_m + 0.5 * (LANE_WIDTH_FACTORS[1] * self.vehicle_width_m + LANE_WIDTH_ADD_M)

    @staticmethod
    def chrono_lane_offset_m(vehicle_width_m: float) -> float:
        """Lane-3 centre offset [m] of Project Chrono's reading of ISO 3888-1 (lane 3's right boundary 3.5 m left of
        lane 1's centre line): 3.5 + (1.2 w + 0.25) / 2 (4.775 m for w = 1.916 m)."""
        return DoubleLaneChangeParams(vehicle_width_m=vehicle_width_m,
                                      lane_offset_from="cone_line").lane3_centre_offset_m()


def iso3888_1_double_lane_change(params: DoubleLaneChangeParams = DoubleLaneChangeParams()) -> Maneuver:
    """ISO 3888-1:2018 double lane change at its native section lengths, driven at 80 km/h (22.2 m/s).

    Geometry (w = vehicle width [m]; reference-data section 3, Project Chrono ``demo_VEH_HMMWV_DoubleLaneChange``
    ``ISO3888_Helper``, ISO 3888-1): lane 1 15 m long, 1.1 w + 0.25 m wide, centred on y = 0; section 2 30 m;
    lane 3 25 m, 1.2 w + 0.25 m, offset 3.5 m to the left; section 4 25 m; lane 5 15 m, 1.3 w + 0.25 m, right
    boundary on lane 1's; run-out 15 m. The lengths and widths agree in every source; where the 3.5 m is measured
    from does not, and the standard's figure was not seen. ``lane_offset_from`` picks the reading
    (``LANE_OFFSET_READINGS``; when not given, ``DEFAULT_LANE_OFFSET_FROM``: ``"cone_line"`` for the planned
    line, ``"lane_centre"`` for the lane-centre line): ``"lane_centre"`` puts lane 3's centre 3.5 m left of lane
    1's, the paper's "3.5 m between the two lanes"; ``"cone_line"`` is Project Chrono's ``ISO3888_Helper`` (the
    only public implementation found that places the cones per the standard): lane 3's right cone line 3.5 m left
    of lane 1's centre line, so lane 3's centre is at 3.5 + (1.2 w + 0.25) / 2 = 4.775 m for w = 1.916 m.

    Reference line (``reference``): ``"lane_centres"`` (default) is built by :func:`tracks.dlc.build_double_lane_change`
    with ``length_scale = 1`` and ``overlap_m`` = 7 m (CHOICE: the transitions span 44 m and 39 m of X; peak v^2
    kappa 0.59 g at 80 km/h with the centre reading, 0.81 g with the cone-line reading; gates anchored at the
    cones); ``"planned"`` is the line of least peak curvature for ``body`` (``tracks.planned_line``). Speed: 80 km/h
    is the nominal test speed the issue gives; the standard's own text was not available to verify it.
    """
    spec = DoubleLaneChangeSpec(vehicle_width_m=params.vehicle_width_m, length_scale=1.0,
                                approach_m=params.approach_m, overlap_m=params.overlap_m,
                                lane_offset_m=params.lane3_centre_offset_m())
    if params.reference == "planned":
        l1, l2, l3, l4, l5, l_out = spec.section_lengths_m()
        (y1, y3, y5), (w1, w3, w5) = spec.lane_centres_m(), spec.lane_widths_m()
        lanes = (LaneSection(l1, w1, y1, "lane 1 (entry)"), LaneSection(l3, w3, y3, "lane 3 (side lane)"),
                 LaneSection(l5, w5, y5, "lane 5 (exit)"))
        path = _planned_path(params, lanes, (l2, l4), approach_m=params.approach_m, run_out_m=l_out,
                             half_width_m=spec.half_width_m, ds_m=spec.ds_m,
                             name=f"iso3888-1_w{params.vehicle_width_m:g}_y{spec.lane_offset_m:g}")
    else:
        path = build_double_lane_change(spec)
    return _at_constant_speed(path, "iso3888_1", "ISO 3888-1:2018", params.speed_mps, "gates",
                              params.vehicle_width_m,
                              "ISO 3888-1 section table (reference-data.md section 3; Project Chrono ISO3888_Helper)")


# ------------------------------------------------------------------------------------------------ ISO 3888-2
MOOSE_LANE_LENGTHS_M = (12.0, 11.0, 12.0)       # sections 1, 3, 5
MOOSE_GAP_LENGTHS_M = (13.5, 12.5)              # sections 2, 4 (total 61 m)
MOOSE_LANE_OFFSET_M = 1.0                       # lane 1 left boundary -> lane 3 right boundary
MOOSE_MIN_EXIT_WIDTH_M = 3.0                    # lane 5 is 1.3 w + 0.25 m but not less than 3 m
MAX_ENTRY_SPEED_KMH = 200.0                     # highest entry speed a manoeuvre accepts [km/h]


@documented
@dataclass(frozen=True)
class ObstacleAvoidanceParams:
    """ISO 3888-2 obstacle avoidance (see :func:`iso3888_2_obstacle_avoidance`)."""

    vehicle_width_m: float = ranged(PAPER_CAR_WIDTH_M, gt=0.5, le=4.0, unit="m")
    # entry speed 80 km/h, at most MAX_ENTRY_SPEED_KMH
    speed_mps: float = ranged(80.0 * KMH_TO_MPS, gt=0.0, le=MAX_ENTRY_SPEED_KMH * KMH_TO_MPS, unit="m/s")
    approach_m: float = ranged(100.0, ge=0.0, le=10000.0, unit="m")
    run_out_m: float = ranged(30.0, ge=0.0, le=10000.0, unit="m")                 # CHOICE: straight after lane 5
    ramp_fraction: float = ranged(0.135, gt=0.0, lt=0.25)                         # transition shape, as the DLC's
    overlap_m: float = ranged(5.0, ge=0.0, le=5.5, unit="m")       # CHOICE: transitions reach 5 m into the lanes
    half_width_m: float = ranged(5.0, gt=0.5, le=50.0, unit="m")                  # road half width (termination)
    ds_m: float = ranged(DEFAULT_DS_M, gt=0.0, le=5.0, unit="m")
    reference: str = "lane_centres"                                 # a key of REFERENCES
    body: BodyRectangle | None = None                               # the car a planned line is for
    max_curvature_rate_per_m2: float | None = ranged(None, gt=0.0, le=10.0, unit="1/m^2")   # planned line only
    planned_margin_m: float = ranged(PLANNED_MARGIN_M, ge=0.0, le=0.5, unit="m")            # planned line only
    planner_version: int = ranged(1, ge=1, le=2, integer=True)      # 1: planned_line, 2: exact_line (unique, exact)

    def __post_init__(self) -> None:
        validate(self)
        _check_reference(self)

    def lane_widths_m(self) -> tuple[float, float, float]:
        """Widths of lanes 1, 3, 5 [m]: 1.1 w + 0.25, w + 1, max(1.3 w + 0.25, 3)."""
        w = self.vehicle_width_m
        return 1.1 * w + 0.25, w + 1.0, max(1.3 * w + 0.25, MOOSE_MIN_EXIT_WIDTH_M)

    def lane_centres_m(self) -> tuple[float, float, float]:
        """Global Y of the centres of lanes 1, 3, 5 [m]: lane 1 on y = 0; lane 3's right boundary 1 m left of
        lane 1's left boundary; lane 5's right boundary on lane 1's right boundary."""
        w1, w3, w5 = self.lane_widths_m()
        return 0.0, 0.5 * w1 + MOOSE_LANE_OFFSET_M + 0.5 * w3, 0.5 * (w5 - w1)


def iso3888_2_obstacle_avoidance(params: ObstacleAvoidanceParams = ObstacleAvoidanceParams()) -> Maneuver:
    """ISO 3888-2:2011 severe lane change, obstacle avoidance (the "moose test"), entry speed 80 km/h.

    Geometry (w = vehicle width [m]), verified against Project Chrono's ``ISO3888_Helper`` (variant ISO3888_2 in
    ``demo_VEH_HMMWV_DoubleLaneChange.cpp``, authors R. Serban, R. Gericke) and the standard's clause 4.1 ("the
    lengths of track sections are fixed, while the track width is a function of vehicle width; the total length
    of the track shall be 61 m", BS ISO 3888-2:2011 public excerpt):

    =======  ==========  =========================  =========================================================
    section  length [m]  width [m]                  lateral placement
    =======  ==========  =========================  =========================================================
    1        12          1.1 w + 0.25               centred on y = 0
    2        13.5        -                          lane change left
    3        11          w + 1                      right boundary 1 m left of lane 1's left boundary
    4        12.5        -                          lane change back
    5        12          1.3 w + 0.25, >= 3         right boundary on lane 1's right boundary
    =======  ==========  =========================  =========================================================

    12 + 13.5 + 11 + 12.5 + 12 = 61 m. Chrono uses a fixed 3 m for lane 5, which equals max(1.3 w + 0.25, 3) for
    w <= 2.115 m. Entry speed: 80 km/h is the commonly cited entry speed (throttle released at the entry of
    section 1); the standard's Annex A text was not available, so this value is NOT verified here. The run-out
    after lane 5 (``run_out_m``) is a CHOICE. Reference line (``reference``): ``"lane_centres"`` (default),
    transitions reaching ``overlap_m`` = 5 m into the lanes (lane 3 keeps 1 m of straight), gates anchored at the
    cones, peak v^2 kappa 1.75 g at 80 km/h (see the module docstring); ``"planned"``, the line of least peak
    curvature for ``body`` (``tracks.planned_line``): 1.11 g at 80 km/h for the paper car, above its own
    steady-state limit (about 0.8 g), so no car of this width passes at a constant 80 km/h; the standard's
    protocol is an entry speed and a coast, whose physical bound is ``feasibility.entry_speed_bound_kmh``.
    """
    p = params
    w1, w3, w5 = p.lane_widths_m()
    y1, y3, y5 = p.lane_centres_m()
    l1, l3, l5 = MOOSE_LANE_LENGTHS_M
    lanes = (LaneSection(l1, w1, y1, "lane 1 (entry)"), LaneSection(l3, w3, y3, "lane 3 (avoidance lane)"),
             LaneSection(l5, w5, y5, "lane 5 (exit)"))
    if p.reference == "planned":
        path = _planned_path(p, lanes, MOOSE_GAP_LENGTHS_M, approach_m=p.approach_m, run_out_m=p.run_out_m,
                             half_width_m=p.half_width_m, ds_m=p.ds_m, name=f"iso3888-2_w{p.vehicle_width_m:g}")
    else:
        path = lane_sequence_path(lanes, MOOSE_GAP_LENGTHS_M, approach_m=p.approach_m, run_out_m=p.run_out_m,
                                  ramp_fraction=p.ramp_fraction, half_width_m=p.half_width_m, ds_m=p.ds_m,
                                  name=f"iso3888-2_w{p.vehicle_width_m:g}_o{p.overlap_m:g}", version=VERSION,
                                  overlap_m=p.overlap_m)
    return _at_constant_speed(path, "iso3888_2", "ISO 3888-2:2011", p.speed_mps, "gates",
                              p.vehicle_width_m,
                              "ISO 3888-2:2011 clause 4.1 / Table 1 as in Project Chrono ISO3888_Helper (ISO3888_2)")


# ------------------------------------------------------------------------------------------------ ISO 4138
@documented
@dataclass(frozen=True)
class SteadyStateCircleParams:
    """ISO 4138 constant-radius steady-state circular driving with a slow speed ramp (see
    :func:`iso4138_steady_state_circle`)."""

    radius_m: float = ranged(40.0, ge=10.0, le=500.0, unit="m")               # CHOICE: 40 m
    friction_mu: float = ranged(0.9, gt=0.0, le=2.0)                          # road friction (the paper's 0.9)
    v_start_mps: float = ranged(5.0, gt=0.0, le=50.0, unit="m/s")
    accel_mps2: float = ranged(0.2, gt=0.0, le=2.0, unit="m/s^2")             # CHOICE: slow, quasi-steady
    overspeed: float = ranged(1.1, ge=1.0, le=2.0)                           # ramp ends at overspeed x v_grip
    lead_in_m: float = ranged(30.0, gt=0.0, le=1000.0, unit="m")              # straight before the circle
    entry_m: float = ranged(20.0, gt=0.0, le=500.0, unit="m")                 # curvature blend 0 -> 1/R
    laps_after_ramp: float = ranged(1.0, ge=0.0, le=10.0)                     # circle kept after the ramp ends
    lateral_tolerance_m: float = ranged(0.5, gt=0.0, le=5.0, unit="m")        # CHOICE: "on the circle"
    half_width_m: float = ranged(4.0, gt=0.5, le=50.0, unit="m")
    ds_m: float = ranged(DEFAULT_DS_M, gt=0.0, le=5.0, unit="m")

    def __post_init__(self) -> None:
        validate(self)

    def grip_limit_speed_mps(self) -> float:
        """sqrt(mu g R) [m/s]."""
        return grip_limit_speed_mps(self.friction_mu, self.radius_m)

    def ramp(self) -> SpeedRamp:
        """The speed profile: v_start up to the end of the entry blend, then +accel up to overspeed x v_grip."""
        v_end = self.overspeed * self.grip_limit_speed_mps()
        if v_end <= self.v_start_mps:
            raise ValueError(f"SteadyStateCircleParams.v_start_mps must be < overspeed x sqrt(mu g R) = {v_end:.3f} "
                             f"m/s (got {self.v_start_mps})")
        return SpeedRamp(self.v_start_mps, v_end, self.accel_mps2, self.lead_in_m + self.entry_m)


def iso4138_steady_state_circle(params: SteadyStateCircleParams = SteadyStateCircleParams()) -> Maneuver:
    """ISO 4138:2021 steady-state circular driving, Method 1 (constant radius), continuous slow speed increase.

    ISO 4138:2021 (clause 8.3, public excerpt) asks for data at lateral-acceleration increments of at most
    0.5 m/s^2 on a constant radius; continuous speed increase is one of its variants. CHOICES (not from the
    standard): R = 40 m; start at 5 m/s (a_y 0.63 m/s^2); accelerate at 0.2 m/s^2, a lateral-acceleration rate
    2 v a / R <= 0.21 m/s^3 at the grip limit (quasi-steady); the ramp ends at 1.1 x the analytic grip-limit speed
    sqrt(mu g R) (18.8 m/s for mu = 0.9, R = 40 m), so it crosses the limit. Path: a ``lead_in_m`` straight (the
    car starts there, so the first projection is unique), a C^2 blend of ``entry_m`` from kappa = 0 to 1/R, then
    the circle (left turn) for the ramp plus ``laps_after_ramp`` laps. The laps lie on one circle: the path
    overlaps itself (project with an s guess, as the env does).
    """
    p = params
    ramp = p.ramp()
    arc_m = ramp.ramp_length_m + p.laps_after_ramp * 2.0 * math.pi * p.radius_m + 1.0
    segs = [(p.lead_in_m, 0.0), (p.entry_m, 1.0 / p.radius_m), (arc_m, 1.0 / p.radius_m)]
    path = Path.from_curvature(CurvatureProfile.from_segments(0.0, segs), ds_m=p.ds_m, closed=False,
                               half_width_m=p.half_width_m, name=f"iso4138_r{p.radius_m:g}", version=VERSION)
    travel_s = (ramp.s_start_m / p.v_start_mps + ramp.ramp_duration_s
                + p.laps_after_ramp * 2.0 * math.pi * p.radius_m / ramp.v_end_mps)
    return Maneuver(path, ManeuverSpec(
        name="iso4138_circle", standard="ISO 4138:2021 (method 1, constant radius)",
        nominal_speed_mps=ramp.v_end_mps, speed_profile=ramp,
        time_limit_s=float(math.ceil(TIME_FACTOR * travel_s + TIME_MARGIN_S)), success_criterion="circle",
        vehicle_width_m=PAPER_CAR_WIDTH_M, lateral_tolerance_m=p.lateral_tolerance_m,
        grip_limit_speed_mps=p.grip_limit_speed_mps(),
        source="ISO 4138:2021 clause 8 (public excerpt); radius, ramp rate and tolerance are CHOICES"))


# ------------------------------------------------------------------------------------------------ slalom
@documented
@dataclass(frozen=True)
class SlalomParams:
    """Slalom through a line of cones (see :func:`slalom`)."""

    vehicle_width_m: float = ranged(PAPER_CAR_WIDTH_M, gt=0.5, le=4.0, unit="m")
    cone_spacing_m: float = ranged(18.0, ge=5.0, le=100.0, unit="m")           # CHOICE: 18 m
    n_cones: int = ranged(10, ge=2, le=100, integer=True)
    clearance_m: float = ranged(0.5, gt=0.0, le=5.0, unit="m")                 # body side to cone centre line
    cone_radius_m: float = ranged(0.15, gt=0.0, le=0.5, unit="m")              # CHOICE: cone base radius
    speed_mps: float = ranged(40.0 * KMH_TO_MPS, gt=0.0, le=100.0, unit="m/s")  # CHOICE: 40 km/h
    approach_m: float = ranged(60.0, gt=0.0, le=10000.0, unit="m")
    run_out_m: float = ranged(30.0, gt=0.0, le=10000.0, unit="m")
    ramp_fraction: float = ranged(0.135, gt=0.0, lt=0.25)
    half_width_m: float = ranged(5.0, gt=0.5, le=50.0, unit="m")
    ds_m: float = ranged(DEFAULT_DS_M, gt=0.0, le=5.0, unit="m")
    reference: str = "lane_centres"                                 # a key of REFERENCES
    body: BodyRectangle | None = None                               # the car a planned line is for
    max_curvature_rate_per_m2: float | None = ranged(None, gt=0.0, le=10.0, unit="1/m^2")   # planned line only
    planned_margin_m: float = ranged(PLANNED_MARGIN_M, gt=0.0, le=0.5, unit="m")            # planned line only

    def __post_init__(self) -> None:
        validate(self)
        _check_reference(self)
        if self.amplitude_m + 0.5 * self.vehicle_width_m >= self.half_width_m:
            raise ValueError(f"SlalomParams.half_width_m must exceed the weave amplitude plus half the car width "
                             f"({self.amplitude_m + 0.5 * self.vehicle_width_m:.3f} m, got {self.half_width_m})")

    @property
    def amplitude_m(self) -> float:
        """Lateral offset of the reference line from the cone line at each cone [m]: w / 2 + clearance."""
        return 0.5 * self.vehicle_width_m + self.clearance_m


def slalom(params: SlalomParams = SlalomParams()) -> Maneuver:
    """Slalom: ``n_cones`` cones on the line y = 0, ``cone_spacing_m`` apart (first at x = ``approach_m``),
    passed on alternate sides, the first on its left (the car on the cone's left).

    No ISO standard defines a slalom; the 18 m spacing, 10 cones, 40 km/h and the 0.5 m clearance are CHOICES
    (18 m is a spacing used in magazine handling tests; not verified here). Reference line: at each cone it is
    straight and parallel to the cone line at y = +-A, A = w / 2 + clearance (1.458 m for w = 1.916 m), and
    between cones a C^2 lane-change pulse moves it 2 A sideways; peak v^2 kappa at 40 km/h is 0.59 g for the
    defaults. Gates: one per cone, anchored at the cone (x in [x_cone - r, x_cone + r], r the cone base radius),
    the allowed side from the cone's edge (y = +r or -r from the cone line) to the road edge.
    """
    p = params
    a = p.amplitude_m
    k_peak, length = transition(-2.0 * a, p.cone_spacing_m, p.ramp_fraction)
    segs: list[tuple[float, float]] = [(p.approach_m, 0.0)]
    gates: list[Gate] = []
    s = p.approach_m
    r = p.cone_radius_m
    for i in range(p.n_cones):
        left_of_cone = i % 2 == 0                 # the car passes cone i on the cone's left
        x_cone = p.approach_m + i * p.cone_spacing_m
        far = a + p.half_width_m                  # the road edge on the passing side, from the cone line
        lane = (far, r) if left_of_cone else (-r, -far)
        gates.append(Gate(s - r, s + r, *lane, f"cone {i + 1} (pass {'left' if left_of_cone else 'right'})",
                          anchor=(x_cone - r, 0.0, 0.0), length_m=2.0 * r))
        if i < p.n_cones - 1:
            segs += pulse_segments(k_peak if left_of_cone else -k_peak, length, p.ramp_fraction)
            s += length
    segs.append((p.run_out_m, 0.0))
    if p.reference == "planned":
        path = _planned_slalom_path(p, gates)
    else:
        path = Path.from_curvature(CurvatureProfile.from_segments(0.0, segs), ds_m=p.ds_m, closed=False, y0_m=a,
                                   half_width_m=p.half_width_m, name=f"slalom_{p.cone_spacing_m:g}m_{p.n_cones}",
                                   version=VERSION, gates=tuple(gates))
    return _at_constant_speed(path, "slalom", "none (CHOICE)", p.speed_mps, "gates",
                              p.vehicle_width_m,
                              "CHOICE: 18 m cone spacing, 10 cones, 40 km/h, 0.5 m clearance")


def _planned_slalom_path(p: SlalomParams, gates: list[Gate]) -> Path:
    """The planned line past the cones, planned with the body ``clearance_m`` from each cone's line (as the
    lane-centre line), judged by the cone gates themselves (re-stationed on the planned line)."""
    inner = max(p.clearance_m, p.cone_radius_m)
    far = p.amplitude_m + p.half_width_m
    lanes = tuple(LaneSection(2.0 * p.cone_radius_m, far - inner, (1.0 if i % 2 == 0 else -1.0) * 0.5 * (far + inner),
                              g.name) for i, g in enumerate(gates))
    gaps = (p.cone_spacing_m - 2.0 * p.cone_radius_m,) * (p.n_cones - 1)
    planned = _planned_path(p, lanes, gaps, approach_m=p.approach_m - p.cone_radius_m, run_out_m=p.run_out_m,
                            half_width_m=p.half_width_m, ds_m=p.ds_m, name=f"slalom_{p.cone_spacing_m:g}m_{p.n_cones}")
    x_rows = planned.table[:, 0]
    cone_gates = []
    for g in gates:
        assert g.anchor is not None
        s0, s1 = np.interp([g.anchor[0], g.anchor[0] + g.lane_length_m], x_rows, planned.s_m)
        cone_gates.append(dataclasses.replace(g, s_start_m=float(s0), s_end_m=float(s1)))
    return dataclasses.replace(planned, gates=tuple(cone_gates))


# ------------------------------------------------------------------------------------------------ step curvature
@documented
@dataclass(frozen=True)
class StepCurvatureParams:
    """Straight into a constant radius (see :func:`step_curvature`)."""

    radius_m: float = ranged(50.0, ge=5.0, le=1000.0, unit="m")
    speed_mps: float = ranged(15.0, gt=0.0, le=100.0, unit="m/s")             # 54 km/h: a_y = 4.5 m/s^2
    approach_m: float = ranged(60.0, gt=0.0, le=10000.0, unit="m")
    step_length_m: float = ranged(1.0, gt=0.0, le=50.0, unit="m")            # blend length of the kappa step
    turn_deg: float = ranged(180.0, gt=0.0, le=340.0, unit="deg")            # arc after the step (no overlap)
    half_width_m: float = ranged(4.0, gt=0.5, le=50.0, unit="m")
    ds_m: float = ranged(DEFAULT_DS_M, gt=0.0, le=5.0, unit="m")

    def __post_init__(self) -> None:
        validate(self)


def step_curvature(params: StepCurvatureParams = StepCurvatureParams()) -> Maneuver:
    """A straight of ``approach_m`` into a left arc of radius ``radius_m`` turning ``turn_deg``: a curvature step
    that shows a controller's overshoot of e_y. CHOICES (no standard): R = 50 m at 15 m/s (54 km/h, a_y =
    4.5 m/s^2 = 0.46 g), 60 m straight, 180 deg. The step is a smootherstep blend over ``step_length_m`` (1 m), so
    the table's dkappa/ds stays finite (max 1.875 / (R step_length_m)) while the step is sharp at any preview
    distance a controller uses.
    """
    p = params
    k = 1.0 / p.radius_m
    arc_m = math.radians(p.turn_deg) * p.radius_m
    segs = [(p.approach_m, 0.0), (p.step_length_m, k), (arc_m, k)]
    path = Path.from_curvature(CurvatureProfile.from_segments(0.0, segs), ds_m=p.ds_m, closed=False,
                               half_width_m=p.half_width_m, name=f"step_curvature_r{p.radius_m:g}", version=VERSION)
    return _at_constant_speed(path, "step_curvature", "none (CHOICE)", p.speed_mps, "end",
                              PAPER_CAR_WIDTH_M,
                              "CHOICE: R = 50 m, 15 m/s, 60 m straight, 1 m curvature blend")


# ------------------------------------------------------------------------------------------------ by name
MANEUVERS: dict[str, tuple[Callable[[Any], Maneuver], type]] = {
    "iso3888_1": (iso3888_1_double_lane_change, DoubleLaneChangeParams),
    "iso3888_2": (iso3888_2_obstacle_avoidance, ObstacleAvoidanceParams),
    "iso4138_circle": (iso4138_steady_state_circle, SteadyStateCircleParams),
    "slalom": (slalom, SlalomParams),
    "step_curvature": (step_curvature, StepCurvatureParams),
}
"""name -> (builder, parameter class)."""


def build_maneuver(name: str, **params: Any) -> Maneuver:
    """The manoeuvre ``name`` (a key of ``MANEUVERS``) with its parameter class built from ``params``."""
    if name not in MANEUVERS:
        raise ValueError(f"unknown manoeuvre {name!r}; known: {sorted(MANEUVERS)}")
    builder, params_cls = MANEUVERS[name]
    return builder(params_cls(**params))


__all__ = ["GRAVITY_MPS2", "MANEUVERS", "SUCCESS_CRITERIA", "DoubleLaneChangeParams", "Maneuver", "ManeuverSpec",
           "ObstacleAvoidanceParams", "SlalomParams", "SteadyStateCircleParams", "StepCurvatureParams",
           "build_maneuver", "grip_limit_speed_mps", "iso3888_1_double_lane_change", "iso3888_2_obstacle_avoidance",
           "iso4138_steady_state_circle", "slalom", "step_curvature"]
