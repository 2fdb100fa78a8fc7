"""The scenario registry: every registered env id is one ``ScenarioConfig`` entry of ``SCENARIOS`` (data only).

A scenario names its track source (a built-in track, a CSV file, a ``tracks.Path`` or the procedural bank), its
speed profile (``None``: hold ``target_speed_mps``), the start (initial speed, share of standstill starts), the
time limit, the road half widths (the path's own per-station widths, or a constant), the success criterion and
the vehicle. ``registration.register_envs`` registers ``vtrack/<name>`` for every entry and the historical
un-namespaced ids (``LEGACY_IDS``) as aliases with the same entry points and arguments.

Imports nothing heavy (``vtrack_gym.tracks``, numpy only, is imported for the manoeuvre scenarios' specs).

The standard manoeuvres (``tracks.maneuvers``) are scenarios too (``MANEUVER_IDS``): ``vtrack/ISO3888-1-v0``,
``vtrack/ISO3888-2-v0``, ``vtrack/ISO4138-Circle-v0``, ``vtrack/Slalom-v0``, ``vtrack/StepCurvature-v0``, each with
its ``ManeuverSpec``'s speed profile, time limit and success criterion (``MANEUVER_CRITERIA``).
"""

from __future__ import annotations

import numbers
import os
from dataclasses import dataclass
from typing import Any

from vtrack_gym._ranges import documented, ranged, validate

KMH = 1.0 / 3.6
"""One km/h in m/s."""

MAX_EPISODE_S = 7200.0
"""Longest time limit of an episode [s] of simulated time (2 h, 720k control steps at 10 ms), given or derived: a
slower lap (a crawl round a long track) is refused rather than run for days with its trace growing in memory."""

MAX_TRACK_SMOOTHING_M = 50.0
"""Largest ``smoothing_m`` [m] (RMS deviation of the fit from a CSV file's points) a scenario accepts."""

NAMESPACE = "vtrack"
"""Gymnasium namespace of the registered ids (``vtrack/DLC120-v0``)."""
MANEUVER_TRACK_NAMES: tuple[str, ...] = ("iso3888_1", "iso3888_2", "iso4138_circle", "slalom", "step_curvature")
"""The standard manoeuvres (``tracks.maneuvers.MANEUVERS``) a scenario may name as its track; a gated one is built
for the driven car's body width (ISO 3888 sizes its lanes from the vehicle width)."""
BUILTIN_TRACK_NAMES: tuple[str, ...] = ("handling_course", "double_lane_change", "procedural", "training_mix",
                                        *MANEUVER_TRACK_NAMES)
"""Track names a scenario may give as a string (besides a CSV file path)."""
SUCCESS_CRITERIA: tuple[str, ...] = ("auto", "lap", "gates", "end", "circle")
"""``lap``: one lap of a closed course within the road; ``gates``: the course completed and every cone gate passed
with the body inside it; ``end``: the end of an open track reached within the road; ``circle`` (ISO 4138): |e_y| <=
``lateral_tolerance_m`` at every step until the ramp reaches ``grip_limit_speed_mps`` = sqrt(mu g R) (or the
course is completed), or the car leaves the band only at its own grip limit: its peak |a_y| in the band is at least
``circle_limit_share`` (0.95, CHOICE) of its peak |a_y| on the whole circle (where it slides at the limit), and
that peak is at least 0.5 mu g. The plant's limit lies below mu g (Pacejka peak factors D < 1, load transfer,
drive force; the SUV's more so), so a criterion fixed at a share of mu g would judge the car, not the driver;
``auto``: ``gates`` if the path has gates, else ``lap`` (closed) or ``end`` (open)."""


RANDOMISED_RANGES: dict[str, tuple[float, float]] = {"friction_range": (0.1, 1.5), "mass_scale_range": (0.5, 2.0),
                                                   "sensor_noise_range": (0.0, 5.0),
                                                   "steering_rate_scale_range": (0.25, 10.0),
                                                   "initial_lateral_offset_range_m": (-2.0, 2.0),
                                                   "initial_heading_error_range_rad": (-0.5, 0.5)}
"""The allowed span of each domain-randomisation range of a scenario (the matching reset option's range)."""


MAX_TARGET_SPEED_MPS = 45.0
"""Highest target speed [m/s] of a scenario (``target_speed_mps`` and ``target_speed_range_mps``)."""


def _is_speed_range(value: object) -> bool:
    """True for a (low, high) pair of real numbers with 0 < low <= high <= ``MAX_TARGET_SPEED_MPS``."""
    if not isinstance(value, (tuple, list)) or len(value) != 2:
        return False
    if any(isinstance(v, bool) or not isinstance(v, numbers.Real) for v in value):
        return False
    return 0.0 < value[0] <= value[1] <= MAX_TARGET_SPEED_MPS


@documented
@dataclass(frozen=True)
class ScenarioConfig:
    """One scenario: track, speed profile, start, time limit, road widths, success criterion and vehicle.

    ``track``: a name of ``BUILTIN_TRACK_NAMES``, a CSV file path or a ``tracks.Path``. ``speed_profile``: a
    ``tracks`` speed profile (``ConstantSpeed``, ``CurvatureLimited``, ``FileSpeed``) followed along the path,
    or ``None`` to hold ``target_speed_mps`` (the paper scenarios). ``half_width_m``: constant drivable half
    width either side [m], or ``None`` for the path's own (per-station) widths. ``max_episode_s`` ``None``: the
    time limit is derived from the track and profile (1.5 x the profile's lap time + 30 s); either way at most
    ``MAX_EPISODE_S`` (2 h; a track and profile deriving more are refused, naming the lap time).
    """

    name: str
    track: Any = "handling_course"                # str | os.PathLike | tracks.Path
    target_speed_mps: float = ranged(11.0, gt=0.0, le=MAX_TARGET_SPEED_MPS, unit="m/s")
    initial_speed_mps: float = ranged(0.0, ge=0.0, le=45.0, unit="m/s")
    max_episode_s: float | None = ranged(None, gt=0.0, le=MAX_EPISODE_S, unit="s")
    target_speed_range_mps: tuple[float, float] | None = None  # randomised per episode (training variant)
    # procedural tracks built once per env, drawn per episode
    procedural_bank_size: int = ranged(16, ge=1, integer=True)
    procedural_seed: int = 12345
    procedural_length_m: float = 800.0
    end_margin_m: float = 5.0                    # open paths: completed this far before the end
    # share of episodes starting at rest (the others at target speed)
    standstill_start_fraction: float = ranged(0.0, ge=0.0, le=1.0)
    speed_profile: Any = None                    # tracks.SpeedProfile | None
    half_width_m: float | None = ranged(None, gt=0.0, le=50.0, unit="m")
    # CSV track files only: force a closed loop (True) or an open road (False), None detects it; the spline fit's
    # allowed RMS deviation from the points [m], None chooses it from the coordinates' rounding
    track_closed: bool | None = None
    track_smoothing_m: float | None = ranged(None, ge=0.0, le=MAX_TRACK_SMOOTHING_M, unit="m")
    success: str = "auto"
    vehicle: str = "default"                     # vehicle preset name (carried; vehicles as data live in vehicle/)
    # ``circle`` criterion only: the lateral band [m] and the analytic grip-limit speed sqrt(mu g R) [m/s]
    lateral_tolerance_m: float | None = ranged(None, gt=0.0, le=5.0, unit="m")
    grip_limit_speed_mps: float | None = ranged(None, gt=0.0, le=100.0, unit="m/s")
    # ... and the share of the episode's peak |a_y| to hold in the band (CHOICE, see SUCCESS_CRITERIA)
    circle_limit_share: float = ranged(0.95, gt=0.0, le=1.0)
    # Domain randomisation, drawn per episode where the reset options leave the knob at its default:
    # friction mu, mass scale and sensor-noise scale uniform in these ranges (None: off), actuator delay a whole
    # number of control periods uniform in [0, max_actuator_delay_s], steering rate-limit scale uniform in
    # steering_rate_scale_range, start offset from the path [m] and heading error [rad] uniform in theirs.
    friction_range: tuple[float, float] | None = None
    mass_scale_range: tuple[float, float] | None = None
    sensor_noise_range: tuple[float, float] | None = None
    max_actuator_delay_s: float = ranged(0.0, ge=0.0, le=0.5, unit="s")
    steering_rate_scale_range: tuple[float, float] | None = None
    initial_lateral_offset_range_m: tuple[float, float] | None = None
    initial_heading_error_range_rad: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        track = self.track
        if isinstance(track, str) and not track:
            raise ValueError("ScenarioConfig.track must not be empty")
        if not isinstance(track, (str, os.PathLike)):
            from vtrack_gym.tracks.path import Path

            if not isinstance(track, Path):
                raise ValueError(f"ScenarioConfig.track must be one of {', '.join(BUILTIN_TRACK_NAMES)}, a CSV file "
                                 f"path or a tracks.Path (got {type(track).__name__})")
        if self.speed_profile is not None:
            from vtrack_gym.tracks.speed_profiles import SpeedProfile

            if not isinstance(self.speed_profile, SpeedProfile):
                raise ValueError("ScenarioConfig.speed_profile must be a tracks speed profile (ConstantSpeed, "
                                 f"CurvatureLimited, FileSpeed) or None (got {type(self.speed_profile).__name__})")
        if self.track_closed is not None and not isinstance(self.track_closed, bool):
            raise ValueError(f"ScenarioConfig.track_closed must be True, False or None (got {self.track_closed!r})")
        if (self.track_closed is not None or self.track_smoothing_m is not None) and (
                not isinstance(track, (str, os.PathLike)) or self.is_builtin):
            raise ValueError("closed= and smoothing_m= apply to a CSV track file only (got track "
                             f"{track if isinstance(track, str) else type(track).__name__!r}); a tracks.Path or a "
                             "built-in track is used as it is")
        if self.target_speed_range_mps is not None and not _is_speed_range(self.target_speed_range_mps):
            raise ValueError("ScenarioConfig.target_speed_range_mps must be None or (low, high) m/s with 0 < low <= "
                             f"high <= {MAX_TARGET_SPEED_MPS} (got {self.target_speed_range_mps!r})")
        if self.success not in SUCCESS_CRITERIA:
            raise ValueError(f"ScenarioConfig.success must be one of {', '.join(SUCCESS_CRITERIA)} "
                             f"(got {self.success!r})")
        if self.success == "circle" and (self.lateral_tolerance_m is None or self.grip_limit_speed_mps is None):
            raise ValueError("ScenarioConfig.lateral_tolerance_m and grip_limit_speed_mps must be set (> 0) for the "
                             "'circle' success criterion")
        if not isinstance(self.vehicle, str) or not self.vehicle:
            raise ValueError(f"ScenarioConfig.vehicle must be a vehicle name (got {self.vehicle!r})")
        for name, (lo, hi) in RANDOMISED_RANGES.items():
            value = getattr(self, name)
            if value is not None and not (isinstance(value, tuple) and len(value) == 2
                                          and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                                  for v in value) and lo <= value[0] <= value[1] <= hi):
                raise ValueError(f"ScenarioConfig.{name} must be None or a (low, high) tuple with "
                                 f"{lo} <= low <= high <= {hi} (got {value!r})")
        validate(self)

    @property
    def is_builtin(self) -> bool:
        """True when the track is one of ``BUILTIN_TRACK_NAMES`` (not a file or a Path)."""
        return isinstance(self.track, str) and self.track in BUILTIN_TRACK_NAMES

    @property
    def env_id(self) -> str:
        """The namespaced Gymnasium id of this scenario (``vtrack/<name>``)."""
        return f"{NAMESPACE}/{self.name}"

    @property
    def max_episode_steps(self) -> int | None:
        """Control steps of the time limit at the default 10 ms period (``None`` when derived from the track)."""
        return None if self.max_episode_s is None else round(self.max_episode_s / 0.01)


LATERAL_TRACKING = ScenarioConfig("LateralTracking-v0", "handling_course", 40.0 * KMH, 0.0, 300.0)
"""Case 1: handling course from standstill, hold 40 km/h, one lap (~2.3 km, ~215 s)."""

DLC120 = ScenarioConfig("DLC120-v0", "double_lane_change", 120.0 * KMH, 120.0 * KMH, 30.0)
"""Case 2: ISO 3888-1 double lane change at 120 km/h from the start of the approach."""

RANDOM_TRACKS = ScenarioConfig("LateralTrackingRandom-v0", "procedural", 15.0, 15.0, 90.0,
                               target_speed_range_mps=(6.0, 35.0), procedural_bank_size=32,
                               standstill_start_fraction=0.2)
"""Training variant: a bank of 32 procedural tracks (half twisty, radii down to 18 m; half highway-like, down to
120 m), target speed drawn per episode in 6-35 m/s but capped so the track's tightest curve needs at most 0.85 g;
the car starts at the target speed, or at rest in 20 % of the episodes (Case 1 starts at rest)."""


def _training_mix() -> ScenarioConfig:
    from vtrack_gym.tracks.training_mix import TrainingMixProfile

    return ScenarioConfig("TrainingMix-v0", "training_mix", 15.0, 15.0, 60.0, procedural_bank_size=60,
                          standstill_start_fraction=0.2, speed_profile=TrainingMixProfile(),
                          friction_range=(0.7, 1.1), mass_scale_range=(0.8, 1.25), sensor_noise_range=(0.0, 1.0),
                          max_actuator_delay_s=0.05, steering_rate_scale_range=(1.0, 4.0),
                          initial_lateral_offset_range_m=(-1.5, 1.5), initial_heading_error_range_rad=(-0.15, 0.15))


TRAINING_MIX = _training_mix()
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

TRACK = ScenarioConfig("Track-v0", "handling_course", TRACK_DEFAULT_MAX_SPEED_MPS, 0.0, None)
"""Any track (``gym.make("vtrack/Track-v0", track=..., speed_profile=...)``), from standstill; default track the
handling course, default profile ``curvature_limited(40 km/h, 0.7 g)`` (``default_track_profile``)."""

MANEUVER_IDS: dict[str, str] = {"iso3888_1": "ISO3888-1-v0", "iso3888_2": "ISO3888-2-v0",
                                 "iso4138_circle": "ISO4138-Circle-v0", "slalom": "Slalom-v0",
                                 "step_curvature": "StepCurvature-v0"}
"""Manoeuvre name (``tracks.maneuvers.MANEUVERS``) -> scenario name (registered as ``vtrack/<name>``)."""
MANEUVER_CRITERIA: dict[str, str] = {"no_cones_hit": "gates", "stays_on_circle": "circle", "completes": "end"}
"""``ManeuverSpec.success_criterion`` -> the scenario's ``success``."""


def maneuver_path(name: str, vehicle_width_m: float) -> Any:
    """The reference path of manoeuvre ``name``; gated manoeuvres are sized for ``vehicle_width_m`` [m]."""
    from vtrack_gym.tracks.maneuvers import build_maneuver

    return build_maneuver(name, **_width_param(name, vehicle_width_m)).path


def _width_param(name: str, vehicle_width_m: float) -> dict[str, float]:
    from dataclasses import fields

    from vtrack_gym.tracks.maneuvers import MANEUVERS

    has_width = any(f.name == "vehicle_width_m" for f in fields(MANEUVERS[name][1]))
    return {"vehicle_width_m": float(vehicle_width_m)} if has_width else {}


def maneuver_scenario(name: str) -> ScenarioConfig:
    """The scenario of manoeuvre ``name``: its path (built per car width), speed profile, time limit and success
    criterion from its ``ManeuverSpec``; the car starts at the profile's first speed, on the approach straight."""
    from vtrack_gym.tracks.maneuvers import build_maneuver

    m = build_maneuver(name)
    spec = m.spec
    return ScenarioConfig(MANEUVER_IDS[name], name, spec.nominal_speed_mps,
                          float(spec.speed_profile.row_speeds(m.path)[0]),
                          spec.time_limit_s, speed_profile=spec.speed_profile,
                          success=MANEUVER_CRITERIA[spec.success_criterion],
                          lateral_tolerance_m=spec.lateral_tolerance_m, grip_limit_speed_mps=spec.grip_limit_speed_mps)


MANEUVER_SCENARIOS: tuple[ScenarioConfig, ...] = tuple(maneuver_scenario(n) for n in MANEUVER_TRACK_NAMES)
"""The standard manoeuvres as scenarios (``vtrack/ISO3888-1-v0``, ...), in ``MANEUVER_TRACK_NAMES`` order."""

SCENARIOS: dict[str, ScenarioConfig] = {s.name: s for s in (LATERAL_TRACKING, DLC120, RANDOM_TRACKS, TRAINING_MIX,
                                                            TRACK, *MANEUVER_SCENARIOS)}
"""Scenario name -> scenario; one registered id ``vtrack/<name>`` per entry."""
LEGACY_IDS: tuple[str, ...] = ("LateralTracking-v0", "DLC120-v0", "LateralTrackingRandom-v0")
"""The historical un-namespaced ids, registered as aliases of ``vtrack/<id>``."""


def default_track_profile() -> Any:
    """Track-v0's default speed profile: ``CurvatureLimited(40 km/h, 0.7 g)``."""
    from vtrack_gym.tracks.speed_profiles import CurvatureLimited
    from vtrack_gym.vehicle.params import GRAVITY_MPS2  # lazily: `import vtrack_gym` stays registry-only

    return CurvatureLimited(TRACK_DEFAULT_MAX_SPEED_MPS, TRACK_DEFAULT_MAX_LATERAL_G * GRAVITY_MPS2)


def scenario_named(name: str) -> ScenarioConfig:
    """The scenario of an id (``vtrack/DLC120-v0`` or ``DLC120-v0``); ``ValueError`` listing the valid ids."""
    key = name[len(NAMESPACE) + 1:] if name.startswith(NAMESPACE + "/") else name
    if key not in SCENARIOS:
        raise ValueError(f"unknown scenario {name!r}; valid: "
                         f"{', '.join(s.env_id for s in SCENARIOS.values())}, {', '.join(LEGACY_IDS)}")
    return SCENARIOS[key]


def with_track(scenario: ScenarioConfig, track: Any = None, speed_profile: Any = None,
               half_width_m: float | None = None, closed: bool | None = None,
               smoothing_m: float | None = None) -> ScenarioConfig:
    """``scenario`` on another track / speed profile / constant half width (``None`` keeps the scenario's).

    ``speed_profile``: a tracks speed profile, a number (constant speed [m/s]) or ``"file"`` (the track's speed
    column). ``closed`` (bool) and ``smoothing_m`` [m] say how a CSV track file is read (see ``load_track``;
    ValueError for any other track). A scenario that drives on a user's track with no profile given gets
    ``default_track_profile()``.
    """
    from dataclasses import replace

    changes: dict[str, Any] = {}
    if track is not None:
        changes["track"] = track
    if speed_profile is not None:
        from vtrack_gym.tracks.speed_profiles import as_speed_profile

        changes["speed_profile"] = as_speed_profile(speed_profile)
    if half_width_m is not None:
        changes["half_width_m"] = float(half_width_m)
    if closed is not None:
        changes["track_closed"] = closed
    if smoothing_m is not None:
        if isinstance(smoothing_m, bool) or not isinstance(smoothing_m, (int, float)):
            raise ValueError(f"smoothing_m must be a number of metres (got {smoothing_m!r})")
        changes["track_smoothing_m"] = float(smoothing_m)
    out = replace(scenario, **changes) if changes else scenario
    if out.speed_profile is None and out.name == TRACK.name:
        out = replace(out, speed_profile=default_track_profile())
    return out


def resolve_scenario(scenario: str | ScenarioConfig, track: Any = None, speed_profile: Any = None,
                     half_width_m: float | None = None, closed: bool | None = None,
                     smoothing_m: float | None = None) -> ScenarioConfig:
    """The scenario an env is made with: a registered name or id, or a ``ScenarioConfig``, then ``with_track``."""
    if isinstance(scenario, str) and _registered_track(scenario) is not None:  # an id of registration.register_track
        kwargs = _registered_track(scenario)
        scenario = kwargs["scenario"]
        track = kwargs.get("track") if track is None else track
        speed_profile = kwargs.get("speed_profile") if speed_profile is None else speed_profile
        closed = kwargs.get("closed") if closed is None else closed
        smoothing_m = kwargs.get("smoothing_m") if smoothing_m is None else smoothing_m
    sc = scenario_named(scenario) if isinstance(scenario, str) else scenario
    if not isinstance(sc, ScenarioConfig):
        raise ValueError(f"scenario must be a scenario id or a ScenarioConfig (got {type(scenario).__name__})")
    return with_track(sc, track, speed_profile, half_width_m, closed, smoothing_m)


def _registered_track(env_id: str) -> dict[str, Any] | None:
    """The make kwargs of a Gymnasium id registered for a user's track (``registration.register_track``), else None."""
    if env_id in SCENARIOS or not env_id.startswith(f"{NAMESPACE}/Track-"):
        return None
    from gymnasium.envs.registration import registry

    spec = registry.get(env_id)
    if spec is None or spec.kwargs.get("scenario") not in SCENARIOS or "track" not in spec.kwargs:
        return None
    return dict(spec.kwargs)
