"""The documentation page of every registered env id, generated from the scenario registry (Gymnasium's env
page template: description, action space, observation space, rewards, starting state, episode end, arguments,
version history).

``env_pages()`` returns one Markdown page per scenario (``docs/gen_env_pages.py`` writes them when the docs site is
built); ``tests/test_env_docs.py`` checks that every registered id has a description and a version history here,
so adding a scenario without documenting it fails the tests.
"""

from __future__ import annotations

from typing import Any

DESCRIPTIONS: dict[str, str] = {
    "LateralTracking-v0": "Case 1 of the paper: one lap of the closed 2.33 km handling course (elevation -2.5 to "
                          "+5.2 m, radii down to 20 m) from standstill, the PD-FLC holding 40 km/h.",
    "DLC120-v0": "Case 2 of the paper: the ISO 3888-1 double lane change at 120 km/h, from the start of the "
                 "approach at speed. The ISO gate widths are kept and the section lengths doubled (the native "
                 "lengths need about 3.2 g at 120 km/h; doubled, the centre line needs the paper's ~0.8 g).",
    "LateralTrackingRandom-v0": "A training variant: a bank of 32 procedural tracks (half twisty, radii down to "
                                "18 m; half highway-like, down to 120 m), the set speed drawn per episode in "
                                "6-35 m/s but capped so the tightest curve needs at most 0.85 g; 20 % of the "
                                "episodes start at rest. The imitation recipes' training env.",
    "TrainingMix-v0": "The RL training distribution: 60 roads (half cone-lined lane-change courses at 15-37 m/s, a "
                      "sixth each twisty, highway and hairpin roads), each with its own speed profile; friction, "
                      "mass, sensor noise, actuator delay, steering rate limit and the start's offset and heading "
                      "error drawn per episode; 20 % standstill starts; 60 s episodes.",
    "TrainingMix20Hz-v0": "The training mix (`vtrack/TrainingMix-v0`) with the policy deciding every 50 ms "
                         "(`control_period_s=0.05`): the setup the shipped `ppo` and `sac` agents were trained on, "
                         "the default of `vtrack train` and the id of the rl_zoo3 hyperparameter files.",
    "TrainingMixNominal-v0": "The training mix's roads, speed profiles and standstill starts with friction and mass "
                             "drawn per episode, without sensor noise, actuator delay, a changed steering rate "
                             "limit or an offset start: the training env of the behaviour-cloning recipe of the "
                             "shipped agent that drives the pedals (`control=\"steer_accel\"`), whose expert, the "
                             "decoupled mpc, drives it without failing.",
    "HandlingCourseCircuit-v0": "The paper's handling course (2.33 km, radii down to 20 m) as a timed "
                                "trajectory: from standstill, one lap of a friction-ellipse speed profile (70 km/h "
                                "cap, 4 m/s^2 lateral, 2 m/s^2 forward, 3 m/s^2 braking, standing start). A "
                                "circuit of the `trajectory` suite.",
    "RingCircuit-v0": "The shipped example map's stadium loop (`ring.gpx`: two 100 m straights, two R 40 m half "
                      "turns entered through 20 m clothoids), one lap from standstill on the circuits' speed "
                      "profile (see `vtrack/HandlingCourseCircuit-v0`). A circuit of the `trajectory` suite.",
    "ProceduralRoad-v0": "An open procedural road (the bank of `LateralTrackingRandom-v0`; the reset seed draws "
                         "which), driven from standstill to its end on the circuits' speed profile (see "
                         "`vtrack/HandlingCourseCircuit-v0`). A course of the `trajectory` suite.",
    "Track-v0": "Any track: `track=` a CSV file (x, y and optional elevation, speed and per-station widths), a "
                "`tracks.Path` or a built-in name, with `speed_profile=` (default curvature-limited at 40 km/h "
                "and 0.7 g). From standstill; the time limit is derived from the track and the profile.",
    "ISO3888-1-v0": "ISO 3888-1 double lane change (severe lane change) with cone gates sized for the car's width, "
                    "driven at a constant speed; success: every gate passed with the body inside it.",
    "ISO3888-2-v0": "ISO 3888-2 obstacle avoidance with cone gates sized for the car's width, driven at a "
                    "constant speed; success: every gate passed with the body inside it.",
    "ISO3888-1-v1": "ISO 3888-1 double lane change as the standard poses it: lane 3 placed by its cone line, the "
                    "car driving the planned line for its own body (the line of least peak curvature through "
                    "lanes sized for its width), entering at 80 km/h (make kwarg `entry_speed_kmh=`) with the "
                    "speed loop holding the entry speed on the approach and the throttle held from the entry gate "
                    "on; success: every gate passed with the body inside it. `reference=\"lane_centres\"` drives "
                    "the lane-centre line instead.",
    "ISO3888-2-v1": "ISO 3888-2 obstacle avoidance as the standard poses it: the car drives the planned line for "
                    "its own body (10 cm clear of the cones) through lanes sized for its width, enters at 50 km/h "
                    "(make kwarg `entry_speed_kmh=`, at most 200 km/h) and coasts from the entry gate on (throttle "
                    "and brake released, the speed loop off); success: every gate passed with the body inside it. "
                    "50 km/h lies below every shipped car's bound on that line (hatchback 61.3, SUV 59.9, sports "
                    "car 65.5 km/h, Formula Student car 93.1 km/h) and its physical bound (67.4, 66.6, 71.7, "
                    "101.5 km/h); the commonly cited 80 km/h lies above the road cars'. "
                    "`reference=\"lane_centres\"` drives the lane-centre line instead.",
    "ISO3888-1-v2": "ISO 3888-1 double lane change as `vtrack/ISO3888-1-v1` poses it (lane 3 by its cone line, "
                    "entry at 80 km/h, the throttle held from the entry gate on), the car driving the planned line "
                    "of `tracks.exact_line` for its own body: one line for given inputs (rounded to 2^-24 m), the "
                    "body held 2 cm clear of every cone line judged exactly, within 5 % of the least peak "
                    "curvature (where 2 cm would ask more, the largest whole millimetre that does not, "
                    "`tracks.exact_margin`: the Formula Student car's margin is 1.9 cm); success: every gate passed "
                    "with the body rectangle inside it, judged exactly between control steps (`tracks.gate_judge`, "
                    "1 mm). `reference=\"lane_centres\"` drives the lane-centre line instead.",
    "ISO3888-2-v2": "ISO 3888-2 obstacle avoidance as `vtrack/ISO3888-2-v1` poses it (entry at 50 km/h, make kwarg "
                    "`entry_speed_kmh=`, then a coast from the entry gate on), the car driving the planned line of "
                    "`tracks.exact_line` for its own body, 2 cm clear of every cone line judged exactly (less "
                    "where 2 cm would ask more than 1.05 x the least peak curvature, `tracks.exact_margin`); success: "
                    "every gate passed with the body rectangle inside it, judged exactly between control steps "
                    "(`tracks.gate_judge`, 1 mm). `reference=\"lane_centres\"` drives the lane-centre line instead.",
    "ISO4138-Circle-v0": "ISO 4138 steady-state circular driving: a slow speed ramp on a constant-radius circle; "
                         "success: the lateral error held within the band until the car's own grip limit.",
    "Slalom-v0": "A slalom between evenly spaced cones at constant speed; success: the end of the course reached "
                 "within the road.",
    "Slalom-v1": "A slalom between evenly spaced cones at the constant 40 km/h of `vtrack/Slalom-v0`, the car "
                 "driving the planned line for its own body past the cones; success: every cone passed on its "
                 "side with the body clear of it. `reference=\"lane_centres\"` drives the v0 line instead.",
    "StepCurvature-v0": "A straight followed by a step into a constant-radius curve (the step-steer response of "
                        "path tracking); success: the end of the course reached within the road.",
    "Race-v0": "A race: `laps=` laps (default 2) of a closed track (default the handling course; `track=` any "
               "closed track Track-v0 reads) from a standing start (`start=\"flying\"`: at speed), the agent on "
               "the steering and the pedals (`control=\"steer_accel\"` or `\"steer_rate_accel\"`); success: "
               "every lap within the track-limit rule (`track_limits=`, default `\"wheels\"`). The reward is "
               "progress along the track less time, track-limit and failure penalties; `info` carries the lap "
               "times and the car's lap-time bound. See [Race](../race.md).",
    "RaceRing-v0": "The race of `vtrack/Race-v0` on the shipped example ring (a 491 m stadium loop, "
                   "`tracks.example_maps`). See [Race](../race.md).",
    "RaceFS-v0": "The race of `vtrack/Race-v0` for the Formula Student car (`vehicle=\"formula_student\"`) on a "
                 "cone-lined Formula Student layout: AMZ Racing's FSI track (215 m between blue and yellow cones, "
                 "3.2-5.0 m wide, `tracks.fs_layouts`); the wheels track-limit rule decides success, the cones the "
                 "body touches are counted (`cones_hit`). See [Formula Student](../formula-student.md).",
}
"""Scenario name -> what the scenario is, for its page."""

VERSION_HISTORY: dict[str, tuple[str, ...]] = {
    name: ("v0: the behaviour pinned by `tests/test_env_versions.py` from release 0.2.0 on (a fixed action "
           "sequence and a fixed follower from fixed seeds: observations, rewards, flags). Before 0.2.0 the id "
           "changed under the same version while the package was in development (the reward, the observation "
           "length 33 -> 43, the spin-out rule); results obtained with a 0.1 release are not comparable.",)
    for name in DESCRIPTIONS
}
"""Scenario name -> its versions, oldest first (a behaviour change is a new version: ``-v1``)."""
_V0_PINNED = VERSION_HISTORY["ISO3888-1-v0"][0]
_ISO1 = (_V0_PINNED + " The lane-centre line, lane 3's centre 3.5 m left of lane 1's, at a constant 80 km/h.",
         "v1: the standard as its cones pose it: lane 3's right cone line 3.5 m left of lane 1's centre line, the "
         "planned line for the driven car's body, entry at 80 km/h with the throttle held from the entry gate on "
         "(make kwargs `entry_speed_kmh=`, `reference=`). v0 stays registered unchanged.")
_ISO2 = (_V0_PINNED + " The lane-centre line at a constant 80 km/h: it asks 1.75 g (1.13 g on the best line) of a "
         "car with a limit of about 0.8 g, so no car could pass it; no longer registered (`gymnasium.make` raises "
         "`gymnasium.error.DeprecatedEnv` naming the latest version).",
         "v1: the planned line for the driven car's body, entry at 50 km/h (below every shipped car's bound) "
         "and a coast from the entry gate on, as the standard's protocol asks (make kwargs "
         "`entry_speed_kmh=`, `reference=`).")
_SLALOM = (_V0_PINNED + " The lane-centre line, 0.5 m clear of each cone.",
           "v1: the planned line for the driven car's body past the cones, same 40 km/h. v0 stays registered "
           "unchanged.")
_V2 = ("v2: the planned line of `tracks.exact_line`: a strictly convex programme with one optimum (v1's linear "
       "programmes had many, and the line moved by up to 0.11 m with the CPU's code paths), the body's rectangle held "
       "clear of the cone lines exactly (v1 sampled its outline every 0.25 m: its 1 cm lines crossed the cone lines by "
       "up to 1.2 cm), 2 cm clear instead of 10 cm, within 5 % of the least peak curvature (v1's line: 1.21-1.26 x; "
       "a car for which 2 cm asks more gets the largest whole millimetre that does not); "
       "the gates judged exactly between control steps (`ConeGates(exact=True)`, metric `min_gate_clearance_m`); the "
       "physical entry-speed bound from the spline's exact curvature. v1 stays registered unchanged.")
_ISO1 = (*_ISO1, _V2)
_ISO2 = (*_ISO2, _V2)
VERSION_HISTORY.update({"ISO3888-1-v0": _ISO1, "ISO3888-1-v1": _ISO1, "ISO3888-1-v2": _ISO1, "ISO3888-2-v1": _ISO2,
                        "ISO3888-2-v2": _ISO2, "Slalom-v0": _SLALOM, "Slalom-v1": _SLALOM})
_RACE = ("v0: pinned by `tests/test_env_versions.py` from its first release (the fixed steering and demand "
         "sequence and the fixed follower of `tests/env_fingerprint.py`).",)
VERSION_HISTORY.update({"Race-v0": _RACE, "RaceRing-v0": _RACE, "RaceFS-v0": _RACE})
DEPRECATED_PAGES: dict[str, tuple[str, ...]] = {"ISO3888-2-v0": _ISO2}
"""Pages of ids no longer registered (``scenarios.DEPRECATED_IDS``): what they were and which id replaces them."""


def env_pages() -> dict[str, str]:
    """File name (``<scenario>.md``) -> Markdown page, for every scenario of the registry, plus ``index.md``."""
    pages = {f"{_name(env_id)}.md": env_page(env_id) for env_id in documented_ids()}
    pages.update({f"{name}.md": deprecated_page(name) for name in DEPRECATED_PAGES})
    pages["index.md"] = _index()
    return pages


def deprecated_page(name: str) -> str:
    """The page of an id that is no longer registered: the id replacing it and the version history."""
    from vtrack_gym.envs.scenarios import DEPRECATED_IDS

    env_id = f"vtrack/{name}"
    new = DEPRECATED_IDS[env_id]
    return (f"# {env_id}\n\nNo longer registered: `gymnasium.make(\"{env_id}\")` raises "
            f"`gymnasium.error.DeprecatedEnv`; use [`{new}`]({_name(new)}.md).\n\n"
            "## Version history\n\n" + "\n".join(f"- {line}" for line in DEPRECATED_PAGES[name]) + "\n")


def documented_ids() -> tuple[str, ...]:
    """Every namespaced id the package registers (one per scenario, plus the training recipes' ids)."""
    from vtrack_gym.envs.registration import CIRCUIT_IDS, NAMESPACED_IDS, RACE_IDS, RECIPE_IDS

    return (*NAMESPACED_IDS, *RECIPE_IDS, *CIRCUIT_IDS, *RACE_IDS)


def _name(env_id: str) -> str:
    return env_id.split("/", 1)[1]


def _index() -> str:
    rows = "\n".join(f"| [`{env_id}`]({_name(env_id)}.md) | {_summary(_name(env_id))} |" for env_id in documented_ids())
    return ("# Environments\n\nEvery id is `gymnasium.make`-able after `import vtrack_gym`; the paper-era ids "
            "`LateralTracking-v0`, `DLC120-v0` and `LateralTrackingRandom-v0` are also registered without the "
            f"`vtrack/` namespace.\n\n| id | scenario |\n|---|---|\n{rows}\n")


def _summary(name: str) -> str:
    """The first sentence of a scenario's description."""
    text = DESCRIPTIONS[name]
    return text[: text.index(". ") + 1] if ". " in text else text


def env_page(env_id: str) -> str:
    """The Markdown page of one registered id (``vtrack/<name>``), from the env it makes."""
    import gymnasium as gym

    from vtrack_gym.envs.registration import register_envs

    register_envs()
    name = _name(env_id)
    env = gym.make(env_id)
    try:
        race = hasattr(env.unwrapped, "lap_time_bound_s")
        sections = [f"# {env_id}", _aliases(name), DESCRIPTIONS[name], _spaces(env), _observation(env),
                    *((_race(),) if race else (_reward(), _control())), _start_and_end(env),
                    _race_arguments() if race else _arguments(), _history(name)]
    finally:
        env.close()
    return "\n\n".join(s for s in sections if s) + "\n"


def _aliases(name: str) -> str:
    from vtrack_gym.envs.registration import ENV_IDS

    return f"Also registered as `{name}` (the paper-era id, identical episodes)." if name in ENV_IDS else ""


def _spaces(env: Any) -> str:
    spec = env.spec
    steps = spec.max_episode_steps if spec is not None else None
    return ("| | |\n|---|---|\n"
            f"| Action space | `{env.action_space}` |\n"
            f"| Observation space | `Box(float32, {env.observation_space.shape})` |\n"
            f"| Control period | {env.unwrapped.config.control_period_s * 1000:g} ms |\n"
            f"| Time limit | {'derived from the track' if steps is None else f'{steps} control steps'} |\n"
            f"| Make | `gymnasium.make(\"{spec.id if spec else ''}\")` |")


def _observation(env: Any) -> str:
    layout = env.unwrapped.observation_layout
    from vtrack_gym.envs.observation import SCALARS

    rows = "\n".join(f"| {i} | `{f.name}` | {f.unit} | {f.doc} |" for i, f in enumerate(SCALARS))
    return ("## Observation space\n\nRaw SI units, named by `vtrack_gym.envs.OBS` (never hard-code positions). "
            f"{layout.size} entries: the scalar fields below, then the curvature preview and the speed preview "
            "(see `vtrack_gym.envs.observation`).\n\n| index | field | unit | meaning |\n|---|---|---|---|\n" + rows)


def _reward() -> str:
    return ("## Action and reward\n\nThe action is the steering command as a fraction of the road-wheel limit "
            "(out-of-range values are clipped; NaN or inf raise `ValueError`). The reward per control step is "
            "`1 - 0.5 |e_y|/(|e_y| + 0.1 m) - 0.2 |e_phi|/(|e_phi| + 0.05 rad) - 0.05 a^2 - 0.1 min((da/0.1)^2, 1)`, "
            "-10 once on a failure termination; every term is in `info[\"reward_*\"]` (weights: "
            "`vtrack_gym.envs.config.RewardConfig`).")


def _control() -> str:
    return ("## Control modes\n\nThe above is the default `control=\"steer\"` (the paper's design: the PD-FLC holds "
            "the speed). `gymnasium.make(id, control=\"steer_accel\")` gives the agent the pedals too: the action is "
            "`Box(-1, 1, (2,))`, the steering command and a longitudinal demand d (d >= 0: throttle fraction d; "
            "d < 0: brake pedal force -d x the car's `brakes.max_pedal_force_n`), the PD-FLC is off; "
            "`control=\"steer_rate_accel\"` takes the steering rate (a fraction of the car's road-wheel rate limit, "
            "integrated by the env) instead of the command. Both append `speed_error` [m/s] and `time_error` [s] to "
            "the observation and add the bounded speed term `-0.1 |e_v|/(|e_v| + 1 m/s)` to the reward; termination "
            "is the same. See [Control modes](../control-modes.md).")


def _race() -> str:
    return ("## Action and reward\n\nThe action is `[steering command, longitudinal demand]` "
            "(`control=\"steer_accel\"`; `\"steer_rate_accel\"`: the steering rate), as in "
            "[Control modes](../control-modes.md); the observation "
            "ends with `speed_error`, `time_error`, `edge_left_m`, `edge_right_m` and `lap_fraction`. The reward per "
            "step is `100 dp/L - 10 T/T_b - 1 cost - 50 [failure]`: centre-line progress dp per lap length L (ground "
            "gained beyond the track-limit rule is not paid), the control period T per lap-time bound T_b, a step "
            "beyond the rule, a failure (`vtrack_gym.envs.race_reward.RaceReward`); the terms are in "
            "`info[\"race_reward_*\"]`. See [Race](../race.md).")


def _race_arguments() -> str:
    return ("## Arguments\n\n`track=` (a closed track), `laps=` (1 to 20), `start=\"standing\"|\"flying\"`, "
            "`control=\"steer_accel\"|\"steer_rate_accel\"` (`\"steer\"` is refused), `track_limits=`, "
            "`time_limit_factor=` (the time limit in lap-time bounds per lap, default 3), `reward=` (a `RaceReward`), "
            "`margin_m=` (the bound's racing line clearance), `vehicle=` and every env config field.")


def _start_and_end(env: Any) -> str:
    scenario = env.unwrapped.scenario
    crit = type(scenario.success).__name__
    return ("## Starting state and episode end\n\n"
            f"Start: `{scenario.start}`; randomisation: `{scenario.randomisation}`; speed: `{scenario.speed}`.\n\n"
            f"`terminated` on `completed`, `off_road`, `spin_out` or `wheel_lift` (in `info[\"termination\"]`); "
            f"`truncated` only at the time limit. `info[\"success\"]` is the verdict of the `{crit}` success "
            "criterion (`vtrack_gym.envs.criteria`).")


def _arguments() -> str:
    return ("## Arguments\n\n`gymnasium.make(id, vehicle=\"suv\")` drives another car (a name of "
            "`vtrack_gym.vehicle.list_vehicles()` or a vehicle file); `control_period_s=` sets the decision period "
            "[s]; `control=` the control mode (above); `vtrack/Track-v0` also takes `track=` (a CSV file, an "
            "OpenDRIVE, Lanelet2, CommonRoad or GPX map: "
            "[Drive a map](../tutorials/drive-a-map.md)), `speed_profile=`, `half_width_m=`, `closed=`, "
            "`smoothing_m=`, `allow_self_crossing=` and `track_options=` (format, route, lane, road_width_m); the "
            "cone-lined standard ids (`vtrack/ISO3888-1-v1`, `vtrack/ISO3888-2-v1`, "
            "`vtrack/Slalom-v1`) take `reference=\"planned\"` (default) or `\"lane_centres\"`, and the two ISO 3888 "
            "ids `entry_speed_kmh=` (in (0, 200] km/h); every id driving a road between edges (not the cone-lined "
            "manoeuvres, not the circle) takes `track_limits=\"wheels\"`, `\"body\"` or `\"centre\"`; in a "
            "longitudinal control mode `LateralTracking-v0` takes `launch=\"powertrain\"` (the held speed reached "
            "from rest along a ramp the car can drive: [Control modes](../control-modes.md)). "
            "Reset options: see [Getting started](../getting-started.md).")


def _history(name: str) -> str:
    return "## Version history\n\n" + "\n".join(f"- {line}" for line in VERSION_HISTORY[name])
