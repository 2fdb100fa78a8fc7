"""The scenario registry: every registered env id is one ``Scenario`` entry of ``SCENARIOS`` (data only).

A scenario is a composition of small frozen parts, keyword-only: its track source (``TrackSource``: a built-in
track of ``track_sources.TRACKS``, a CSV file or a ``tracks.Path``), reference line (``CentreLine``, or
``PlannedLine`` on a cone-lined manoeuvre), speed protocol (``speed.HoldSpeed``, ``speed.EntryThenRelease`` or a
``tracks`` speed profile), start (``randomisation.Start``), domain randomisation
(``randomisation.Randomisation``), success criterion (a class of ``criteria``), vehicle (a name of
``vehicle.list_vehicles()``, a vehicle file or ``VehicleParams``; ``None``: the env config's car) and control
period, plus its time limit. ``registration.register_envs`` registers ``vtrack/<name>`` for every entry and the
historical un-namespaced ids (``LEGACY_IDS``) as aliases; ``vtrack/Track-v0`` composes the same parts from its
make kwargs (``with_track``).

The standard manoeuvres (``tracks.maneuvers``) are scenarios too (``MANEUVER_IDS``, the current version of each):
``vtrack/ISO3888-1-v2``, ``vtrack/ISO3888-2-v2``, ``vtrack/ISO4138-Circle-v0``, ``vtrack/Slalom-v1``,
``vtrack/StepCurvature-v0``. The cone-lined ones (``STANDARD_MANEUVERS``) drive the planned line for the
driven car's body and the standards' speed protocols (``EntryThenRelease``); the ISO 3888 ones (-v2) the line of
``tracks.exact_line`` with their gates judged exactly. The others keep their ``ManeuverSpec``'s speed profile.
``vtrack/ISO3888-1-v0``, ``vtrack/Slalom-v0``, ``vtrack/ISO3888-1-v1`` and ``vtrack/ISO3888-2-v1`` stay
registered unchanged (``LEGACY_MANEUVER_SCENARIOS``); ``vtrack/ISO3888-2-v0`` asked 1.13 g of a car that has
0.81 g and is no longer registered, so Gymnasium refuses it with ``gymnasium.error.DeprecatedEnv`` naming
``vtrack/ISO3888-2-v1``.

Imports nothing heavy (``vtrack_gym.tracks``, numpy only, is imported for the manoeuvre scenarios' specs).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Any

from vtrack_gym._ranges import documented, ranged, validate
from vtrack_gym.envs.criteria import (
    CRITERIA,
    TRACK_LIMIT_RULES,
    Auto,
    ConeGates,
    EndReached,
    SuccessCriterion,
    TrackLimits,
)
from vtrack_gym.envs.randomisation import Randomisation, Start
from vtrack_gym.envs.speed import EntryThenRelease, HoldSpeed, check_speed, is_profile, speed_part
from vtrack_gym.envs.track_sources import MANEUVER_TRACK_NAMES, READ_KWARGS, TrackSource

KMH = 1.0 / 3.6
"""One km/h in m/s."""

MAX_EPISODE_S = 7200.0
"""Longest time limit of an episode [s] of simulated time (2 h, 720k control steps at 10 ms), given or derived: a
slower lap (a crawl round a long track) is refused rather than run for days with its trace growing in memory."""

NAMESPACE = "vtrack"
"""Gymnasium namespace of the registered ids (``vtrack/DLC120-v0``)."""


@dataclass(frozen=True)
class ReferenceLine:
    """A scenario's reference-line part: which line of its track source the car tracks."""

    def paths(self, source: TrackSource, vehicle: Any) -> tuple:
        """The reference paths of ``source`` for the driven car ``vehicle`` (``VehicleParams``)."""
        raise NotImplementedError


@dataclass(frozen=True)
class CentreLine(ReferenceLine):
    """The reference line is the track's centre-line (the path itself; a manoeuvre's lane-centre line)."""

    def paths(self, source: TrackSource, vehicle: Any) -> tuple:
        """The track source's paths, gated ones sized for the car's body width."""
        return source.paths(vehicle.chassis.body_width_m)


TRACKING_MARGIN_M = 0.1
"""Clearance [m] between the body and every cone line on the line a ``PlannedLine`` scenario drives. The line of
least peak curvature (1 cm clear, ``tracks.feasibility.entry_speed_bound_kmh``'s physical bound) grazes the cones,
so a closed loop tracking it within a few centimetres still hits them (the ``nmpc`` baseline hit 3 cones of
ISO 3888-2 at 40 km/h with |e_y| <= 4.2 cm); 10 cm leaves a controller room at a modest cost in curvature
(ISO 3888-2, hatchback, coasting from 60 km/h: 0.96 of the car's limit instead of 0.79)."""


@documented
@dataclass(frozen=True)
class PlannedLine(ReferenceLine):
    """The line of least peak curvature along which the driven car's body passes every cone gate of a cone-lined
    manoeuvre ``margin_m`` [m] clear of every cone line (``tracks.feasibility.planned_maneuver``: lanes sized for
    its width, planned for its body rectangle, curvature rate within its steering rate). ValueError naming the
    field, the limit and the car for a car too wide for the manoeuvre's lanes.

    ``peak_ratio`` (``planner_version`` 2 only; None: ``margin_m`` as given): ``margin_m`` is the target of the
    margin rule (``tracks.exact_margin``), cut for a car whose line would ask more than ``peak_ratio`` x the
    least-curvature line's peak curvature to the largest whole millimetre that does not (``margin_for``)."""

    margin_m: float = ranged(TRACKING_MARGIN_M, ge=0.0, le=0.5, unit="m")
    planner_version: int = ranged(1, ge=1, le=2, integer=True)   # 2: tracks.exact_line (unique, exact geometry)
    peak_ratio: float | None = ranged(None, ge=1.0, le=2.0)       # the margin rule's bound (planner version 2)

    def __post_init__(self) -> None:
        validate(self)
        if self.peak_ratio is not None and self.planner_version != 2:
            raise ValueError(f"PlannedLine.peak_ratio applies to planner_version 2 (got planner_version "
                             f"{self.planner_version})")
        if self.peak_ratio is not None:
            self.rule()                       # ValueError for a target that is not a whole number of steps

    def rule(self) -> Any:
        """The margin rule (``tracks.exact_margin.MarginRule``) of this line: target ``margin_m``, ``peak_ratio``."""
        from vtrack_gym.tracks.exact_margin import MarginRule

        return MarginRule(target_m=self.margin_m, peak_ratio=self.peak_ratio)

    def margin_for(self, source: TrackSource, vehicle: Any) -> float:
        """The margin [m] the line of ``source``'s manoeuvre is planned with for ``vehicle`` (``VehicleParams``):
        ``margin_m``, or the margin rule's result with ``peak_ratio`` set (``tracks.exact_margin.exact_margin_m``:
        shipped for the shipped cars, computed for any other)."""
        if self.peak_ratio is None:
            return self.margin_m
        from vtrack_gym.tracks.exact_margin import exact_margin_m

        return exact_margin_m(source.track, vehicle, self.rule())

    def paths(self, source: TrackSource, vehicle: Any) -> tuple:
        """The planned line of the source's manoeuvre for ``vehicle``."""
        if self.planner_version == 1:
            return source.planned_paths(vehicle, self.margin_m)
        return source.planned_paths(vehicle, self.margin_for(source, vehicle), self.planner_version)


EXACT_TRACKING_MARGIN_M = 0.02
"""Target clearance [m] between the body and every cone line on the line the -v2 ISO 3888 ids drive
(``PlannedLine`` with ``planner_version=2``). The body is checked exactly (``tracks.exact_line``,
``tracks.gate_judge``), so the margin is room for a controller's tracking error only, not for a sampled judge's
blind spots. Cut by the margin rule (``EXACT_PEAK_RATIO``) where 2 cm would cost a car more than 5 % of peak
curvature over its least-curvature line (0 cm): the road cars keep 2 cm on both tests, the Formula Student car
gets 1.9 cm on ISO 3888-1 (tested)."""
EXACT_PEAK_RATIO = 1.05
"""The margin rule's bound (``PlannedLine.peak_ratio``, ``tracks.exact_margin``): the -v2 line asks at most this
times the least-curvature line's peak curvature; its margin is ``EXACT_TRACKING_MARGIN_M`` or, where that would
ask more, the largest whole millimetre below it that does not."""


REFERENCE_LINES: dict[str, ReferenceLine] = {"planned": PlannedLine(), "lane_centres": CentreLine()}
"""Make kwarg ``reference=`` of the -v1 cone-lined standard ids -> reference-line part."""
EXACT_REFERENCE_LINES: dict[str, ReferenceLine] = {
    "planned": PlannedLine(margin_m=EXACT_TRACKING_MARGIN_M, planner_version=2, peak_ratio=EXACT_PEAK_RATIO),
    "lane_centres": CentreLine()}
"""Make kwarg ``reference=`` of the cone-lined standard ids -> reference-line part (``tracks.maneuvers.REFERENCES``)."""


@documented
@dataclass(frozen=True, kw_only=True)
class Scenario:
    """One scenario, composed of parts (see the module docstring); every field keyword-only.

    ``time_limit_s`` ``None``: derived from the track and speed protocol (1.5 x the profile's lap time + 30 s);
    either way at most ``MAX_EPISODE_S`` (2 h; a track and profile deriving more are refused, naming the lap time).
    """

    name: str
    track: TrackSource = field(default_factory=TrackSource)
    reference: ReferenceLine = field(default_factory=CentreLine)
    speed: Any = field(default_factory=lambda: HoldSpeed(target_speed_mps=11.0))  # HoldSpeed | SpeedProfile
    start: Start = field(default_factory=Start)
    randomisation: Randomisation = field(default_factory=Randomisation)
    success: SuccessCriterion = field(default_factory=Auto)
    vehicle: Any = None                      # str | os.PathLike | VehicleParams | None (the env config's car)
    control_period_s: float = ranged(0.01, ge=0.001, le=0.1, unit="s")
    time_limit_s: float | None = ranged(None, gt=0.0, le=MAX_EPISODE_S, unit="s")

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise ValueError(f"Scenario.name must be a non-empty string (got {self.name!r})")
        for part, cls in (("track", TrackSource), ("reference", ReferenceLine), ("start", Start),
                          ("randomisation", Randomisation), ("success", SuccessCriterion)):
            if not isinstance(getattr(self, part), cls):
                raise ValueError(f"Scenario.{part} must be a {cls.__name__} (got "
                                 f"{type(getattr(self, part)).__name__})")
        check_speed(self.speed)
        if self.vehicle is not None and (isinstance(self.vehicle, str) and not self.vehicle):
            raise ValueError("Scenario.vehicle must be a vehicle name, a vehicle file, VehicleParams or None")
        validate(self)

    @property
    def env_id(self) -> str:
        """The namespaced Gymnasium id of this scenario (``vtrack/<name>``)."""
        return f"{NAMESPACE}/{self.name}"

    @property
    def max_episode_steps(self) -> int | None:
        """Control steps of the time limit (``None`` when derived from the track)."""
        return None if self.time_limit_s is None else round(self.time_limit_s / self.control_period_s)

    @property
    def speed_profile(self) -> Any:
        """The speed profile followed along the path, ``None`` for a held speed."""
        return self.speed if is_profile(self.speed) else None


LATERAL_TRACKING = Scenario(name="LateralTracking-v0", track=TrackSource(track="handling_course"),
                            speed=HoldSpeed(target_speed_mps=40.0 * KMH), time_limit_s=300.0)
"""Case 1: handling course from standstill, hold 40 km/h, one lap (~2.3 km, ~215 s)."""

DLC120 = Scenario(name="DLC120-v0", track=TrackSource(track="double_lane_change"),
                  speed=HoldSpeed(target_speed_mps=120.0 * KMH), start=Start(at_speed=True), time_limit_s=30.0)
"""Case 2: ISO 3888-1 double lane change at 120 km/h from the start of the approach."""

RANDOM_TRACKS = Scenario(name="LateralTrackingRandom-v0", track=TrackSource(track="procedural", bank_size=32),
                         speed=HoldSpeed(target_speed_mps=15.0, random_range_mps=(6.0, 35.0)),
                         start=Start(at_speed=True, standstill_fraction=0.2), time_limit_s=90.0)
"""Training variant: a bank of 32 procedural tracks (half twisty, radii down to 18 m; half highway-like, down to
120 m), target speed drawn per episode in 6-35 m/s but capped so the track's tightest curve needs at most 0.85 g;
the car starts at the target speed, or at rest in 20 % of the episodes (Case 1 starts at rest)."""


def _training_mix() -> Scenario:
    from vtrack_gym.tracks.training_mix import TrainingMixProfile

    return Scenario(name="TrainingMix-v0", track=TrackSource(track="training_mix", bank_size=60),
                    speed=TrainingMixProfile(), start=Start(at_speed=True, standstill_fraction=0.2),
                    randomisation=Randomisation(
                        friction_range=(0.7, 1.1), mass_scale_range=(0.8, 1.25), sensor_noise_range=(0.0, 1.0),
                        max_actuator_delay_s=0.05, steering_rate_scale_range=(1.0, 4.0),
                        initial_lateral_offset_range_m=(-1.5, 1.5), initial_heading_error_range_rad=(-0.15, 0.15)),
                    time_limit_s=60.0)


TRAINING_MIX = _training_mix()
TRAINING_MIX_NOMINAL = replace(
    TRAINING_MIX, name="TrainingMixNominal-v0",
    randomisation=Randomisation(friction_range=(0.7, 1.1), mass_scale_range=(0.8, 1.25)))
"""The training mix's roads, speed profiles, standstill starts and drawn friction and mass, without sensor noise,
actuator delay, a changed steering rate limit or an offset start: what a model-based expert (the decoupled mpc)
drives without failing, so its demonstrations are worth cloning (the behaviour-cloning recipes in
``control="steer_accel"``)."""
"""The RL training distribution (``tracks.training_mix``): 60 roads, half of them lane-change courses (8 cone-lined
lanes 2.5-4 m left or right and back at 15-37 m/s, 0.4-0.85 g), a sixth each twisty (R >= 18 m), highway
(R >= 120 m) and hairpin (R >= 5.5 m) roads, each with its own speed profile; 20 % standstill starts; friction
0.7-1.1, mass x0.8-1.25, sensor noise 0-1 x nominal, actuator delay 0-50 ms and a steering rate limit 1-4 x the
car's own drawn per episode; every episode starts up to 1.5 m off the path and 0.15 rad off its heading (so that
large errors, and recovering from them, are part of what is learnt); 60 s episodes. Covers every evaluation regime
of the package. The rate-limit draw keeps a policy from learning to chatter between left and right lock, which a
slow actuator would smooth out and a fast one (or another simulator's instant steering) would not."""

TRACK_DEFAULT_MAX_SPEED_MPS = 40.0 * KMH
"""Track-v0's default speed profile: curvature-limited at 40 km/h ..."""
TRACK_DEFAULT_MAX_LATERAL_G = 0.7
"""... and 0.7 g lateral acceleration (2 m/s^2 acceleration, 3 m/s^2 braking)."""

def default_track_profile() -> Any:
    """Track-v0's default speed profile: ``CurvatureLimited(40 km/h, 0.7 g)``."""
    from vtrack_gym.tracks.speed_profiles import CurvatureLimited
    from vtrack_gym.vehicle.params import GRAVITY_MPS2  # lazily: `import vtrack_gym` stays registry-only

    return CurvatureLimited(TRACK_DEFAULT_MAX_SPEED_MPS, TRACK_DEFAULT_MAX_LATERAL_G * GRAVITY_MPS2)


TRACK = Scenario(name="Track-v0", track=TrackSource(track="handling_course"), speed=default_track_profile())
"""Any track (``gym.make("vtrack/Track-v0", track=..., speed_profile=...)``), from standstill; default track the
handling course, default profile ``curvature_limited(40 km/h, 0.7 g)`` (``default_track_profile``); time limit
derived from the track."""

MANEUVER_IDS: dict[str, str] = {"iso3888_1": "ISO3888-1-v2", "iso3888_2": "ISO3888-2-v2",
                                 "iso4138_circle": "ISO4138-Circle-v0", "slalom": "Slalom-v1",
                                 "step_curvature": "StepCurvature-v0"}
"""Manoeuvre name (``tracks.maneuvers.MANEUVERS``) -> the scenario name of its current version (registered as
``vtrack/<name>``)."""
LEGACY_MANEUVER_IDS: dict[str, str] = {"iso3888_1": "ISO3888-1-v0", "slalom": "Slalom-v0"}
"""Older versions still registered unchanged (lane-centre line, constant speed)."""
PLANNED_V1_IDS: dict[str, str] = {"iso3888_1": "ISO3888-1-v1", "iso3888_2": "ISO3888-2-v1"}
"""The first planned-line versions of the ISO 3888 ids, registered unchanged (``planned_line``: the body sampled,
the line one of a linear programme's optima, 10 cm clear)."""
DEPRECATED_IDS: dict[str, str] = {"vtrack/ISO3888-2-v0": "vtrack/ISO3888-2-v2"}
"""Ids no longer registered -> the id Gymnasium's ``DeprecatedEnv`` error names instead."""

ISO3888_2_ENTRY_KMH = 50.0
"""Default entry speed of ``vtrack/ISO3888-2-v1`` [km/h]. Every shipped car can pass it: coasting from the entry
gate, the line the env drives (``TRACKING_MARGIN_M`` clear of the cones) stays within the car's own lateral limit
up to 61.3 km/h (hatchback), 59.9 (SUV) and 65.5 (sports car), and the least-curvature line up to its physical
bound of 67.4, 66.6 and 71.7 km/h (``feasibility.entry_speed_bound_kmh``); 50 km/h also leaves a closed loop room
for its tracking error (the ``nmpc`` baseline passes on the hatchback at 50 km/h and hits a cone at 55). The
standard's commonly cited 80 km/h lies above every car's physical bound: no driver passes it with these tyres."""
ISO3888_1_ENTRY_KMH = 80.0
"""Default entry speed of ``vtrack/ISO3888-1-v1`` [km/h]: the standard's test speed; holding the throttle, every
shipped car stays within its own lateral limit on the line the env drives up to 95 km/h (SUV; 99.5 km/h the
others)."""


def maneuver_criterion(spec: Any) -> SuccessCriterion:
    """The success criterion a ``ManeuverSpec`` names (``spec.success_criterion``, a name of ``criteria.CRITERIA``:
    one vocabulary), built from the spec (``SuccessCriterion.from_maneuver``)."""
    return CRITERIA[spec.success_criterion].from_maneuver(spec)


def maneuver_scenario(name: str, scenario_name: str | None = None) -> Scenario:
    """The lane-centre scenario of manoeuvre ``name`` (the -v0 ids): its path (built per car width), speed
    profile, time limit and success criterion from its ``ManeuverSpec``; the car starts at the profile's first
    speed, on the approach straight."""
    from vtrack_gym.tracks.maneuvers import build_maneuver

    spec = build_maneuver(name).spec
    return Scenario(name=scenario_name or MANEUVER_IDS[name], track=TrackSource(track=name),
                    speed=spec.speed_profile, start=Start(at_speed=True), success=maneuver_criterion(spec),
                    time_limit_s=spec.time_limit_s)


def standard_scenario(name: str, version: int | None = None) -> Scenario:
    """The -v1 scenario of a cone-lined manoeuvre: the planned line for the driven car (``PlannedLine``), its
    lanes sized for the car's width, and the standard's speed protocol: ISO 3888-2 an entry speed then a coast
    (``ISO3888_2_ENTRY_KMH``), ISO 3888-1 an entry speed then the throttle held (``ISO3888_1_ENTRY_KMH``; lane 3
    placed by the ``cone_line`` reading), the slalom its -v0 constant speed. The time limit of the two entry-speed
    protocols is derived per env from the entry speed and the car's predicted speed (1.5 x the run + 30 s).
    ``version`` 2 (the current ISO 3888 ids, None: the current one): the line of ``tracks.exact_line``
    ``EXACT_TRACKING_MARGIN_M`` clear (less where the margin rule, ``EXACT_PEAK_RATIO``, cuts it) and the gates
    judged exactly (``ConeGates(exact=True)``); 1: the -v1 ids."""
    from vtrack_gym.tracks.maneuvers import build_maneuver

    version = version or (2 if name in PLANNED_V1_IDS else 1)
    spec = build_maneuver(name).spec
    speed: Any = spec.speed_profile
    limit: float | None = spec.time_limit_s
    if name == "iso3888_2":
        speed, limit = EntryThenRelease(entry_speed_kmh=ISO3888_2_ENTRY_KMH, after_entry="coast"), None
    elif name == "iso3888_1":
        speed, limit = EntryThenRelease(entry_speed_kmh=ISO3888_1_ENTRY_KMH, after_entry="hold_throttle"), None
    if version == 1:
        return Scenario(name=PLANNED_V1_IDS.get(name, MANEUVER_IDS[name]), track=TrackSource(track=name),
                        reference=PlannedLine(), speed=speed, start=Start(at_speed=True),
                        success=maneuver_criterion(spec), time_limit_s=limit)
    return Scenario(name=MANEUVER_IDS[name], track=TrackSource(track=name), reference=EXACT_REFERENCE_LINES["planned"],
                    speed=speed, start=Start(at_speed=True), success=ConeGates(exact=True), time_limit_s=limit)


STANDARD_MANEUVERS: tuple[str, ...] = ("iso3888_1", "iso3888_2", "slalom")
"""The cone-lined manoeuvres whose current version (-v1) drives the planned line (``tracks.feasibility``'s
``GATED_MANEUVERS``)."""
MANEUVER_SCENARIOS: tuple[Scenario, ...] = tuple(
    standard_scenario(n) if n in STANDARD_MANEUVERS else maneuver_scenario(n) for n in MANEUVER_TRACK_NAMES)
"""The standard manoeuvres' current versions (``vtrack/ISO3888-1-v1``, ...), in ``MANEUVER_TRACK_NAMES`` order."""
LEGACY_MANEUVER_SCENARIOS: tuple[Scenario, ...] = tuple(
    maneuver_scenario(n, v0) for n, v0 in LEGACY_MANEUVER_IDS.items()) + tuple(
    standard_scenario(n, 1) for n in PLANNED_V1_IDS)
"""``vtrack/ISO3888-1-v0``, ``vtrack/Slalom-v0``, ``vtrack/ISO3888-1-v1`` and ``vtrack/ISO3888-2-v1``, registered
unchanged."""

SCENARIOS: dict[str, Scenario] = {s.name: s for s in (LATERAL_TRACKING, DLC120, RANDOM_TRACKS, TRAINING_MIX,
                                                      TRAINING_MIX_NOMINAL, TRACK, *LEGACY_MANEUVER_SCENARIOS,
                                                      *MANEUVER_SCENARIOS)}
"""Scenario name -> scenario; one registered id ``vtrack/<name>`` per entry (``registration.register_scenario``
adds one)."""
LEGACY_IDS: tuple[str, ...] = ("LateralTracking-v0", "DLC120-v0", "LateralTrackingRandom-v0")
"""The historical un-namespaced ids, registered as aliases of ``vtrack/<id>``."""


def scenario_named(name: str) -> Scenario:
    """The scenario of an id (``vtrack/DLC120-v0`` or ``DLC120-v0``); ``ValueError`` listing the valid ids."""
    key = name[len(NAMESPACE) + 1:] if name.startswith(NAMESPACE + "/") else name
    if key not in SCENARIOS:
        raise ValueError(f"unknown scenario {name!r}; valid: "
                         f"{', '.join(s.env_id for s in SCENARIOS.values())}, {', '.join(LEGACY_IDS)}")
    return SCENARIOS[key]


def with_track(scenario: Scenario, track: Any = None, speed_profile: Any = None,
               half_width_m: float | None = None, closed: bool | None = None,
               smoothing_m: float | None = None, read: Mapping[str, Any] | None = None) -> Scenario:
    """``scenario`` with another track source / speed profile / constant half width (``None`` keeps the part).

    ``speed_profile``: a tracks speed profile, a number (constant speed [m/s]) or ``"file"`` (the track's speed
    column). ``closed`` (bool) and ``smoothing_m`` [m] say how a CSV track file is read (see ``load_track``;
    ValueError for any other track). ``read``: the other read options of a track file, ``allow_self_crossing``
    and ``track_options`` (None values ignored). A scenario driven on another track with no profile given keeps its
    speed protocol (Track-v0's: ``default_track_profile()``).
    """
    source: dict[str, Any] = {}
    if track is not None:
        source["track"] = track
    if half_width_m is not None:
        source["half_width_m"] = float(half_width_m)
    if closed is not None:
        source["closed"] = closed
    if smoothing_m is not None:
        if isinstance(smoothing_m, bool) or not isinstance(smoothing_m, (int, float)):
            raise ValueError(f"smoothing_m must be a number of metres (got {smoothing_m!r})")
        source["smoothing_m"] = float(smoothing_m)
    source.update({k: v for k, v in (read or {}).items() if v is not None})
    changes: dict[str, Any] = {"track": replace(scenario.track, **source)} if source else {}
    if speed_profile is not None:
        from vtrack_gym.tracks.speed_profiles import as_speed_profile

        changes["speed"] = as_speed_profile(speed_profile)
    return replace(scenario, **changes) if changes else scenario


def resolve_scenario(scenario: str | Scenario, track: Any = None, speed_profile: Any = None,
                     half_width_m: float | None = None, closed: bool | None = None,
                     smoothing_m: float | None = None, read: Mapping[str, Any] | None = None) -> Scenario:
    """The scenario an env is made with: a registered name or id, or a ``Scenario``, then ``with_track``."""
    if isinstance(scenario, str) and _registered_track(scenario) is not None:  # an id of registration.register_track
        kwargs = _registered_track(scenario)
        scenario = kwargs["scenario"]
        track = kwargs.get("track") if track is None else track
        speed_profile = kwargs.get("speed_profile") if speed_profile is None else speed_profile
        closed = kwargs.get("closed") if closed is None else closed
        smoothing_m = kwargs.get("smoothing_m") if smoothing_m is None else smoothing_m
        read = {**{k: kwargs.get(k) for k in READ_KWARGS}, **{k: v for k, v in (read or {}).items() if v is not None}}
    sc = scenario_named(scenario) if isinstance(scenario, str) else scenario
    if not isinstance(sc, Scenario):
        raise ValueError(f"scenario must be a scenario id or a Scenario (got {type(scenario).__name__})")
    return with_track(sc, track, speed_profile, half_width_m, closed, smoothing_m, read)


def _registered_track(env_id: str) -> dict[str, Any] | None:
    """The make kwargs of a Gymnasium id registered for a user's track (``registration.register_track``), else None."""
    if env_id in SCENARIOS or not env_id.startswith(f"{NAMESPACE}/Track-"):
        return None
    from gymnasium.envs.registration import registry

    spec = registry.get(env_id)
    if spec is None or spec.kwargs.get("scenario") not in SCENARIOS or "track" not in spec.kwargs:
        return None
    return dict(spec.kwargs)



def with_protocol(scenario: Scenario, vehicle: Any, entry_speed_kmh: float | None = None,
                  reference: str | None = None, track_limits: str | None = None, *, launch: str | None = None,
                  control: str = "steer") -> Scenario:
    """``scenario`` with the make kwargs of the standard ids: ``entry_speed_kmh`` [km/h] (an ``EntryThenRelease``
    scenario only; refused outside (0, 200] km/h naming the car, ``feasibility.check_entry_speed``),
    ``reference`` (``"planned"`` or ``"lane_centres"``, ``REFERENCE_LINES``; a cone-lined manoeuvre only),
    ``track_limits`` (``"wheels"``, ``"body"`` or ``"centre"``: ``with_track_limits``) and ``launch``
    (``"step"`` or ``"powertrain"``, ``envs.launch``; a held speed from rest in the env's ``control`` mode, a
    longitudinal one). ``vehicle`` is the driven car (``VehicleParams``); ``None`` keeps a part."""
    if track_limits is not None:
        scenario = with_track_limits(scenario, track_limits)
    if launch is not None or control != "steer":   # a longitudinal mode's step from rest is warned of
        from vtrack_gym.envs.launch import with_launch

        scenario = with_launch(scenario, vehicle, "step" if launch is None else launch, control)
    changes: dict[str, Any] = {}
    if entry_speed_kmh is not None:
        from vtrack_gym.tracks.feasibility import check_entry_speed

        if not speed_part(scenario.speed).takes_entry_speed:
            ids = ", ".join(s.env_id for s in SCENARIOS.values() if speed_part(s.speed).takes_entry_speed)
            raise ValueError(f"entry_speed_kmh applies to the ids with an entry-speed protocol ({ids}); "
                             f"{scenario.env_id} has {type(scenario.speed).__name__}")
        if isinstance(entry_speed_kmh, bool) or not isinstance(entry_speed_kmh, (int, float)):
            raise ValueError(f"entry_speed_kmh must be a number of km/h (got {entry_speed_kmh!r})")
        check_entry_speed(float(entry_speed_kmh), vehicle)
        changes["speed"] = replace(scenario.speed, entry_speed_kmh=float(entry_speed_kmh))
    if reference is not None:
        from vtrack_gym.tracks.feasibility import GATED_MANEUVERS

        if reference not in REFERENCE_LINES:
            raise ValueError(f"reference must be one of {', '.join(REFERENCE_LINES)} (got {reference!r})")
        if not (scenario.track.is_builtin and scenario.track.track in GATED_MANEUVERS):
            raise ValueError(f"reference= applies to the cone-lined manoeuvres ({', '.join(GATED_MANEUVERS)}); "
                             f"{scenario.env_id} drives {scenario.track.track!r}")
        exact = isinstance(scenario.reference, PlannedLine) and scenario.reference.planner_version == 2
        changes["reference"] = (EXACT_REFERENCE_LINES if exact else REFERENCE_LINES)[reference]
    return replace(scenario, **changes) if changes else scenario


def with_track_limits(scenario: Scenario, rule: str) -> Scenario:
    """``scenario`` judged by the track-limit ``rule`` (``criteria.TRACK_LIMIT_RULES``: its success part becomes
    ``TrackLimits(rule=rule)``). Refused (ValueError naming the id) for a scenario judged by its cone gates or its
    circle, whose rule is not the road's edges; a track with cone gates is refused when the env builds it)."""
    if isinstance(rule, str) and rule in TRACK_LIMIT_RULES and isinstance(scenario.success, TrackLimits) and \
            scenario.success.rule == rule:
        return scenario
    criterion = TrackLimits(rule=rule)      # ValueError naming the allowed rules
    if not isinstance(scenario.success, (Auto, EndReached, TrackLimits)):
        raise ValueError(f"track_limits applies to the ids that drive a road between edges; {scenario.env_id} is "
                         f"judged by {type(scenario.success).__name__} on {scenario.track.track!r}")
    return replace(scenario, success=criterion)
