"""``HighwayLaneKeeping``: highway-env's ``lane-keeping-v0`` behind vtrack's observation and action contract.

Any vtrack policy (``make_policy(name, env)``) drives highway-env's ``BicycleVehicle`` unchanged: the adapter reads
the car's state and the lane geometry (``interop.lane_geometry``) after every highway-env step and writes the
``ObservationLayout`` observation through the native env's writer (``interop.lane_observation``); its ``info`` has
the native env's keys (``envs.schema.INFO_KEYS``). It maps the normalised road-wheel command back to highway-env's
steering action. highway-env is
imported only when an adapter is constructed (``pip install vtrack_gym[highway]``); its source is not changed.

Conventions (all checked against highway-env 1.12.1, see ``tests/test_highway_interop.py``):

* Frames. highway-env integrates in a right-handed world frame (x, y) with the heading measured from +x towards
  +y and the body lateral speed along the heading rotated by +90 deg (``BicycleVehicle.derivative_func`` rotates
  ``[speed, lateral_speed]`` by ``R(heading)``). Lane lateral coordinates are along
  ``direction_lateral = (-d_y, d_x)``, i.e. the same +90 deg side. So, in that frame, heading, yaw rate, lateral
  speed, steering angle and lane lateral offset are all LEFT / counter-clockwise positive, like vtrack: no sign
  flip anywhere. (The renderer draws +y downwards, so "left" in this frame appears on the right of the screen;
  that mirror image is the only reason the lane coordinate can look right-positive.)
* ``e_y`` is the signed perpendicular distance of the CG from the reference centre line (the exact closest point,
  Newton iterations), not highway-env's own ``SineLane.local_coordinates`` lateral, which is the offset along the
  chord normal (they differ by up to ~5 % on the sine road, where the centre line is inclined by up to 17 deg).
  Stations ``s`` are arc lengths (highway-env's ``longitudinal`` on a ``SineLane`` is the chord abscissa).
* Reference path: the lane highway-env itself rewards, ``env.lane``, with its own switching rule mirrored (the
  env moves on to the next lane of ``env.lanes`` when the car is no longer ``on_lane``). ``start="sine"`` (the
  default) puts the car on the sine lane with highway-env's own 4 m offset (reset options of
  ``HighwayLaneKeeping``) and makes that lane the rewarded one; ``start="highway"`` keeps highway-env's own
  initial state on its straight entry lane, whose centre line does NOT join the sine lane: at the switch the
  reference jumps (~8 m in ``e_y`` for a car on the entry lane's centre line).
* Action: ``delta = a * max_road_wheel_angle_rad`` with ``max_road_wheel_angle_rad = pi/3`` (lane-keeping-v0's
  ``steering_range``). highway-env maps its action ``u`` linearly from [-1, 1] onto ``steering_range``
  (``ContinuousAction.get_action`` -> ``utils.lmap``), so ``u = 2 (delta - lo)/(hi - lo) - 1`` (= ``a`` for the
  symmetric default). The steering is applied instantly (no actuator lag or rate limit).
* Design model from ``BicycleVehicle``: ``MASS`` (1 kg: highway-env's car is normalised), ``INERTIA_Z``,
  ``LENGTH_A``/``LENGTH_B`` as a1/a2, and AXLE cornering stiffnesses ``2 * FRICTION_FRONT`` and
  ``2 * FRICTION_REAR`` [N/rad]: ``FRICTION_*`` are per-tyre values (``f_yf = 2 * FRICTION_FRONT * (delta_f -
  theta_vf)``, Rajamani eq. 2.25). The tyres are linear (no saturation), hence ``friction_mu`` is a placeholder.
  ``vtrack_gym.vehicle.linear.lateral_matrices`` of this design model equals the Jacobian of highway-env's
  ``derivative_func``; its ``lateral_lpv_dynamics()`` agrees except B[1], which it builds from ONE front tyre
  (``FRICTION_FRONT * LENGTH_A / INERTIA_Z``, half of what its own nonlinear model applies).

Timing: ``control_period_s = 1 / policy_frequency`` of highway-env. lane-keeping-v0 defaults to 10 Hz; the
adapter defaults to 50 Hz (``simulation_frequency = policy_frequency``, one RK4 step per action) because the
sampled baselines assume T_c <= 20 ms (MPC's ``sample_time_s = 0.02`` must be a multiple of T_c, and SMC needs
T_c |K_r| < 1 with K_r = -18.7 1/s at 8.3 m/s). The continuous-time model is identical at any rate.
highway-env's own observation, which the adapter never reads, is configured empty (``LEAN_OBSERVATION``: 40 %
of its step time); its per-step state record ``env.trajectory`` is cleared on reset (its reset never clears it).
Everything else is lane-keeping-v0's configuration; ``highway_config`` overrides any of it.

Episode: the car keeps highway-env's constant speed (8.3 m/s; no longitudinal control). ``completed`` when the
car reaches the end of the last lane (``end_margin_m`` before it) or has covered ``course_length_m``;
``off_road`` when ``|e_y|`` exceeds the reference lane's half width (5 m; highway-env itself never terminates),
checked by default for the sine start only (``terminate_off_road``); ``spin_out`` when ``|e_phi| > pi/2``;
truncated at ``max_episode_s`` (120 s; the default course takes ~61 s). The reward is highway-env's own.

``info`` carries every signal ``vtrack_gym.evaluation`` needs, under ``envs.schema.INFO_KEYS``. What highway-env
does not model is a documented constant: ``z_m = 0``, ``roll_rad = 0``, ``a_z_mps2 = 0`` (flat road, no roll or
heave), ``throttle = 0``, ``brake_n = 0``, ``steering_command_rad`` = the applied road-wheel angle; the reward terms
are ``reward_alive = 1`` and ``reward_tracking = reward - 1`` (0 at reset, the others always 0); ``fz_n`` are
the static wheel loads ``m g a_{2,1} / (2 l)`` (FL, FR, RL, RR). ``a_y_mps2 =
v_y' + r v_x = (F_yf + F_yr)/m`` and ``a_x_mps2 = v_x' - r v_y`` come from highway-env's own state derivative.
highway-env exposes the state only once per control step, so ``acc_substeps_mps2`` holds the (a_x, a_y, a_z)
of the previous and the current control step linearly interpolated onto ``n_acc = ceil(250 Hz x T_c)`` samples
(the ISO 2631-1 weighting in ``vtrack_gym.evaluation`` needs >= 200 Hz) and ``config.physics_dt_s = T_c /
n_acc`` is THAT sample period (highway-env's own integration step is ``config.simulation_dt_s``). The content
that matters here (the 0.08 Hz sine road, ~1 Hz transients) is far below the 25 Hz Nyquist limit of 50 Hz
control-rate samples, so the comfort value is a faithful estimate, not a measurement at the physics rate.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
import numpy as np

from vtrack_gym.envs.config import validate_numeric_options
from vtrack_gym.envs.observation import OBS, ObservationLayout
from vtrack_gym.envs.schema import REWARD_TERMS, info_dict, signal_row
from vtrack_gym.envs.tracking_env import check_action
from vtrack_gym.interop import HIGHWAY_ENV_ID
from vtrack_gym.interop.lane_geometry import LaneGeometry
from vtrack_gym.interop.lane_observation import observe_on_lane
from vtrack_gym.vehicle.params import GRAVITY_MPS2, DesignModel

__all__ = ["HIGHWAY_ENV_ID", "HighwayConfig", "HighwayLaneKeeping", "LaneGeometry", "design_model_from_bicycle",
           "import_highway_env"]  # LaneGeometry lives in interop.lane_geometry (re-exported here)

HIGHWAY_SOURCE_ID = "lane-keeping-v0"
"""The highway-env id the adapter wraps."""

INSTALL_HINT = "pip install vtrack_gym[highway]"

START_MODES: tuple[str, ...] = ("sine", "highway")

LEAN_OBSERVATION: dict[str, Any] = {"type": "AttributesObservation", "attributes": []}
"""highway-env's own observation, which the adapter never reads, computes nothing (-40 % of its step time)."""

ACC_RATE_HZ = 250.0
"""Minimum sample rate of ``info["acc_substeps_mps2"]`` (ISO 2631-1 weighting needs >= 200 Hz)."""


def import_highway_env() -> Any:
    """Import and return the ``highway_env`` module (``ImportError`` with the install hint if it is missing)."""
    try:
        import highway_env
    except ImportError as exc:
        raise ImportError(f"the highway-env adapter needs the optional package highway-env: {INSTALL_HINT}") from exc
    return highway_env


def design_model_from_bicycle(vehicle_cls: Any, max_road_wheel_angle_rad: float, control_period_s: float,
                              steering_ratio: float = 1.0, friction_mu: float = 1.0) -> DesignModel:
    """vtrack's ``DesignModel`` of highway-env's ``BicycleVehicle`` class (or instance).

    Axle cornering stiffness = 2 x the per-tyre ``FRICTION_FRONT`` / ``FRICTION_REAR``. highway-env has no
    steering rate limit: ``max_road_wheel_rate_radps`` is a full lock-to-lock swing in one control period (the
    largest change its zero-order-hold actuator can make), no steering column (``steering_ratio`` 1) and linear
    tyres (``friction_mu`` only a placeholder).
    """
    return DesignModel(
        mass_kg=float(vehicle_cls.MASS),
        yaw_inertia_kgm2=float(vehicle_cls.INERTIA_Z),
        cg_to_front_axle_m=float(vehicle_cls.LENGTH_A),
        cg_to_rear_axle_m=float(vehicle_cls.LENGTH_B),
        front_cornering_stiffness_npr=2.0 * float(vehicle_cls.FRICTION_FRONT),
        rear_cornering_stiffness_npr=2.0 * float(vehicle_cls.FRICTION_REAR),
        max_road_wheel_angle_rad=float(max_road_wheel_angle_rad),
        max_road_wheel_rate_radps=2.0 * float(max_road_wheel_angle_rad) / float(control_period_s),
        steering_ratio=float(steering_ratio),
        friction_mu=float(friction_mu),
    )


@dataclass(frozen=True)
class HighwayConfig:
    """What ``vtrack_gym.evaluation.rollouts.rollout`` reads from ``env.unwrapped.config``, plus the adapter's settings.

    ``physics_dt_s`` is the sample period of ``info["acc_substeps_mps2"]`` (interpolated, see the module
    docstring); ``simulation_dt_s`` is highway-env's RK4 step.

    ``highway_config`` is what was passed to highway-env (``gym.make("lane-keeping-v0", config=...)``): the
    adapter's frequencies updated by the caller's overrides. ``terminate_off_road=None`` means: on for the
    ``sine`` start, off for the ``highway`` start (whose reference jumps at highway-env's lane switch).
    """

    control_period_s: float = 0.02
    physics_dt_s: float = 0.004
    simulation_dt_s: float = 0.02
    model: str = "highway-env BicycleVehicle (linear tyres, RK4)"
    max_episode_s: float = 120.0
    course_length_m: float | None = None
    end_margin_m: float = 5.0
    terminate_off_road: bool | None = None
    start: str = "sine"
    layout: ObservationLayout = OBS
    highway_config: dict[str, Any] = field(default_factory=dict)


@dataclass
class ReferencePath:
    """Centre line(s) of an episode for ``vtrack_gym.evaluation`` (plots read ``table``; no cone ``gates``)."""

    table: np.ndarray
    gates: tuple = ()
    closed: bool = False   # highway-env's lanes are open roads


class HighwayLaneKeeping(gym.Env):
    """highway-env's lane-keeping-v0 with vtrack's observation layout, action space and ``info`` signals.

    Reward: highway-env's own lane-keeping reward ``1 - (lat / lane width)^2``. Reset options: ``start``
    ("sine" | "highway"; default from the constructor) and, for the sine start, ``initial_lateral_offset_m``
    (perpendicular offset from the centre line, left-positive, in [-4.5, 4.5]; default -4, i.e. highway-env's
    own 4 m to the right), ``start_station_m`` (arc length along the sine lane, [0, 400], default 0) and
    ``initial_heading_error_rad`` ([-0.5, 0.5], default 0). highway-env's lane keeping has no randomness that
    reaches the car: the seed changes nothing but highway-env's (unused) observation noise.
    """

    metadata = {"render_modes": ["rgb_array", "human"], "render_fps": 50}  # noqa: RUF012

    RESET_RANGES: dict[str, tuple[float, float]] = {  # noqa: RUF012 - documentation table, read-only
        "initial_lateral_offset_m": (-4.5, 4.5),
        "start_station_m": (0.0, 400.0),
        "initial_heading_error_rad": (-0.5, 0.5),
    }
    RESET_DEFAULTS: dict[str, float] = {  # noqa: RUF012 - documentation table, read-only
        "initial_lateral_offset_m": -4.0,
        "start_station_m": 0.0,
        "initial_heading_error_rad": 0.0,
    }

    def __init__(self, policy_frequency_hz: float = 50.0, start: str = "sine", max_episode_s: float = 120.0,
                 course_length_m: float | None = None, terminate_off_road: bool | None = None,
                 highway_config: dict[str, Any] | None = None, layout: ObservationLayout = OBS,
                 render_mode: str | None = None, control: str = "steer") -> None:
        from vtrack_gym.envs.control import check_control

        if check_control(control) != "steer":
            raise ValueError(f"control must be 'steer' on HighwayLaneKeeping-v0 (got {control!r}): highway-env's "
                             "car keeps its own speed; the longitudinal control modes drive this package's envs")
        self.control = control
        """The control mode (``envs.control``): always ``steer`` here."""
        import_highway_env()
        if not (1.0 <= policy_frequency_hz <= 1000.0):
            raise ValueError(f"policy_frequency_hz must be in [1, 1000] Hz (got {policy_frequency_hz})")
        if start not in START_MODES:
            raise ValueError(f"start must be one of {', '.join(START_MODES)} (got {start!r})")
        if not max_episode_s > 0.0:
            raise ValueError(f"max_episode_s must be > 0 s (got {max_episode_s})")
        if course_length_m is not None and not course_length_m > 0.0:
            raise ValueError(f"course_length_m must be > 0 m or None (got {course_length_m})")
        if not isinstance(layout, ObservationLayout):
            raise ValueError(f"layout must be an ObservationLayout (got {type(layout).__name__})")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']} (got {render_mode!r})")
        hw_cfg = {"policy_frequency": policy_frequency_hz, "simulation_frequency": policy_frequency_hz,
                  "observation": dict(LEAN_OBSERVATION), **(highway_config or {})}
        ratio = hw_cfg["simulation_frequency"] / hw_cfg["policy_frequency"]
        if ratio < 1 or abs(ratio - round(ratio)) > 1e-9:
            raise ValueError("highway_config simulation_frequency must be an integer multiple of policy_frequency")
        self._hw = gym.make(HIGHWAY_SOURCE_ID, config=hw_cfg, disable_env_checker=True).unwrapped
        self._hw.render_mode = render_mode  # LaneKeepingEnv.__init__ takes no render_mode (highway-env 1.12.1)
        act = self._hw.config["action"]
        if act.get("longitudinal", True) or not act.get("lateral", True) or not act.get("dynamical", False):
            raise ValueError("the adapter needs lane-keeping-v0's lateral-only, dynamical ContinuousAction")
        lo, hi = (float(v) for v in act.get("steering_range", (-math.pi / 4, math.pi / 4)))
        delta_max = min(-lo, hi, math.pi / 2)  # BicycleVehicle.clip_actions clips to +-pi/2
        if not delta_max > 0.0:
            raise ValueError(f"lane-keeping-v0's steering_range must contain 0 in its interior (got {(lo, hi)})")
        self._steer_lo, self._steer_span = lo, hi - lo
        period = 1.0 / float(self._hw.config["policy_frequency"])
        n_acc = max(1, math.ceil(ACC_RATE_HZ * period - 1e-9))
        self.config = HighwayConfig(control_period_s=period, physics_dt_s=period / n_acc,
                                    simulation_dt_s=1.0 / float(self._hw.config["simulation_frequency"]),
                                    max_episode_s=float(max_episode_s),
                                    course_length_m=course_length_m, terminate_off_road=terminate_off_road,
                                    start=start, layout=layout, highway_config=dict(hw_cfg))
        self.design_model = design_model_from_bicycle(self._hw.action_type.vehicle_class, delta_max, period)
        self.observation_layout = layout
        self.control_period_s = period
        self.render_mode = render_mode
        self.metadata = {**self.metadata, "render_fps": round(1.0 / period)}
        low, high = layout.bounds()
        self.observation_space = gym.spaces.Box(low, high, dtype=np.float32)
        self.action_space = gym.spaces.Box(-1.0, 1.0, shape=(1,), dtype=np.float32)
        a1, a2 = self.design_model.cg_to_front_axle_m, self.design_model.cg_to_rear_axle_m
        w = self.design_model.mass_kg * GRAVITY_MPS2 / (2.0 * (a1 + a2))
        self._fz = np.array([w * a2, w * a2, w * a1, w * a1])  # static FL, FR, RL, RR [N]
        self._acc_frac = np.arange(1, n_acc + 1, dtype=np.float64)[:, None] / n_acc
        self._acc_prev = np.zeros(3)
        self._geoms: dict[int, LaneGeometry] = {}
        self._geom: LaneGeometry | None = None
        self._path: ReferencePath | None = None
        self._start = start
        self._off_road_check = True
        self._target_speed = 0.0
        self._steps = 0
        self._progress = 0.0
        self._station = 0.0
        self._needs_reset = True

    # ------------------------------------------------------------------------------------------ properties
    @property
    def highway_env(self) -> Any:
        """The wrapped highway-env ``LaneKeepingEnv`` (unwrapped)."""
        return self._hw

    @property
    def vehicle(self) -> Any:
        """highway-env's controlled ``BicycleVehicle``."""
        return self._hw.vehicle

    @property
    def reference_geometry(self) -> LaneGeometry:
        """Geometry of the lane the current observation refers to."""
        if self._geom is None:
            raise RuntimeError("call reset() first")
        return self._geom

    @property
    def current_path(self) -> ReferencePath:
        """Centre lines of this episode's reference lanes (``table``: (N, 2) world x, y; no gates)."""
        if self._hw.lane is None:
            raise RuntimeError("call reset() first")
        if self._path is None:
            lanes = [self._hw.lane, *self._hw.lanes]
            self._path = ReferencePath(np.concatenate([self._geometry(lane).polyline() for lane in lanes]))
        return self._path

    # ------------------------------------------------------------------------------------------- gym API
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        opts = dict(options or {})
        start = opts.pop("start", self.config.start)
        if start not in START_MODES:
            raise ValueError(f"reset option 'start' must be one of {', '.join(START_MODES)} (got {start!r})")
        values = dict(self.RESET_DEFAULTS)
        values.update(validate_numeric_options(opts, self.RESET_RANGES, extra_valid=("start",)))
        if start == "highway" and opts:
            raise ValueError(f"reset options {', '.join(sorted(opts))} only apply to start='sine'")
        self._hw.reset(seed=seed)
        self._hw.trajectory.clear()  # highway-env's per-step state record: its reset never clears it
        self._geoms = {}
        self._path = None
        if start == "sine":
            self._place_on_sine(values["start_station_m"], values["initial_lateral_offset_m"],
                                values["initial_heading_error_rad"])
        check = self.config.terminate_off_road
        self._off_road_check = (start == "sine") if check is None else bool(check)
        self._start = start
        self._target_speed = float(self._hw.vehicle.speed)
        self._steps = 0
        self._progress = 0.0
        self._geom = None
        obs, info = self._observe(stepped=False, reward=None)
        self._acc_prev = info["acc_substeps_mps2"][-1].copy()
        self._needs_reset = False
        return obs, info

    def step(self, action: Any):
        if self._needs_reset:
            raise RuntimeError("call reset() before step() (and after an episode ends)")
        delta = check_action(action) * self.design_model.max_road_wheel_angle_rad
        u = 2.0 * (delta - self._steer_lo) / self._steer_span - 1.0  # inverse of highway-env's utils.lmap
        _, reward, _, _, _ = self._hw.step(np.array([u]))
        self._steps += 1
        obs, info = self._observe(stepped=True, reward=float(reward))
        e_y, e_phi = info["e_y_m"], info["e_phi_rad"]
        termination = ""
        if not (math.isfinite(e_y) and math.isfinite(e_phi)):
            termination = "invalid_state"
        elif self._off_road_check and abs(e_y) > self._geom.half_width:
            termination = "off_road"
        elif abs(e_phi) > 0.5 * math.pi:
            termination = "spin_out"
        elif self._completed():
            termination = "completed"
        terminated = termination != ""
        truncated = not terminated and self._steps * self.control_period_s >= self.config.max_episode_s - 1e-9
        info["termination"] = termination
        info["success"] = termination == "completed"  # the adapter's course has no gates
        info["cost"] = np.float64(termination == "off_road")   # the road at the CG, as the native envs' default
        self._needs_reset = terminated or truncated
        if self.render_mode == "human":
            self.render()
        return obs, float(reward), terminated, truncated, info

    def observe(self) -> tuple[np.ndarray, dict[str, Any]]:
        """Observation and info of highway-env's CURRENT state (e.g. after moving its car by hand)."""
        if self._geom is None:
            raise RuntimeError("call reset() first")
        return self._observe(stepped=False, reward=None)

    def render(self):
        return self._hw.render()

    def close(self) -> None:
        self._hw.close()

    # ------------------------------------------------------------------------------------------- internals
    def _geometry(self, lane: Any) -> LaneGeometry:
        geom = self._geoms.get(id(lane))
        if geom is None:
            geom = self._geoms[id(lane)] = LaneGeometry(lane)
        return geom

    def _reference_lane(self) -> Any:
        """The lane highway-env rewards on its next step (its own switching rule, evaluated without mutating it)."""
        hw = self._hw
        if hw.lanes and not hw.lane.on_lane(hw.vehicle.position):
            return hw.lanes[0]
        return hw.lane

    def _place_on_sine(self, station_m: float, offset_m: float, heading_error_rad: float) -> None:
        """Put highway-env's car on its sine lane and make that lane the rewarded one (entry lane dropped)."""
        from highway_env.road.lane import SineLane

        hw = self._hw
        sine = [lane for lane in (hw.lane, *hw.lanes) if isinstance(lane, SineLane)]
        if not sine:
            raise ValueError("start='sine' needs a SineLane in lane-keeping-v0's road")
        lane = sine[0]
        geom = self._geometry(lane)
        cx, cy = geom.centre(geom.abscissa_at(station_m))
        _, _, psi, _, _ = geom.project(cx, cy)
        veh = hw.vehicle
        veh.position = np.array([cx - offset_m * math.sin(psi), cy + offset_m * math.cos(psi)])
        veh.heading = psi + heading_error_rad
        veh.on_state_update()
        hw.lane = lane
        hw.lanes = []

    def _completed(self) -> bool:
        if self.config.course_length_m is not None and self._progress >= self.config.course_length_m:
            return True
        hw = self._hw
        last = hw.lanes[-1] if hw.lanes else hw.lane
        return self._geom.lane is last and self._station >= self._geom.arc_length - self.config.end_margin_m

    def _acc_samples(self, a_x: float, a_y: float, stepped: bool) -> np.ndarray:
        """(n_acc, 3) accelerations over the last control period (linear from the previous step's values)."""
        cur = np.array((a_x, a_y, 0.0))
        if not stepped:
            return np.tile(cur, (self._acc_frac.shape[0], 1))
        prev, self._acc_prev = self._acc_prev, cur
        return prev + self._acc_frac * (cur - prev)

    def _observe(self, stepped: bool, reward: float | None) -> tuple[np.ndarray, dict[str, Any]]:
        """Observation and ``info`` (``envs.schema.INFO_KEYS``) of highway-env's current state.

        ``reward``: highway-env's reward of the step just taken (``None`` at reset: all reward terms 0). It is
        reported as ``reward_alive = 1`` plus ``reward_tracking = reward - 1`` (its ``1 - (lat / width)^2``).
        """
        veh = self._hw.vehicle
        px, py = (float(c) for c in veh.position)
        psi = float(veh.heading)
        v_x, v_y, r = float(veh.speed), float(veh.lateral_speed), float(veh.yaw_rate)
        delta = float(veh.action["steering"])
        deriv = veh.derivative  # highway-env's own state derivative d/dt [x, y, psi, v_x, v_y, r]
        v_x_dot, v_y_dot = float(deriv[3, 0]), float(deriv[4, 0])
        a_x, a_y = v_x_dot - r * v_y, v_y_dot + r * v_x
        geom = self._geometry(self._reference_lane())
        obs, station, e_y, e_phi = observe_on_lane(geom, self.observation_layout, px, py, psi, v_x, v_y, r, delta,
                                                   v_x_dot, self._target_speed)
        if stepped and geom is self._geom:  # no progress across a lane switch (the stations restart)
            self._progress += station - self._station
        self._geom, self._station = geom, station
        terms = dict.fromkeys(REWARD_TERMS, 0.0)
        if reward is not None:
            terms["reward_alive"], terms["reward_tracking"] = 1.0, reward - 1.0
        row = signal_row(
            x_m=px, y_m=py, z_m=0.0, psi_rad=psi, e_y_m=e_y, e_phi_rad=e_phi, v_mps=v_x, v_y_mps=v_y,
            yaw_rate_radps=r, road_wheel_angle_rad=delta, hand_wheel_angle_rad=delta * self.design_model.steering_ratio,
            steering_command_rad=delta, roll_rad=0.0, throttle=0.0, brake_n=0.0, a_x_mps2=a_x, a_y_mps2=a_y,
            a_z_mps2=0.0, min_fz_n=float(self._fz[0] if self._fz[0] < self._fz[2] else self._fz[2]),
            station_m=station, progress_m=self._progress, target_speed_mps=self._target_speed,
            speed_error_mps=v_x - self._target_speed,
            time_error_s=(self._steps * self.control_period_s - self._progress / self._target_speed
                          if self._target_speed > 0.0 else 0.0), **terms)
        info = info_dict(self._steps * self.control_period_s, row, self._fz.copy(),
                         self._acc_samples(a_x, a_y, stepped), "")
        return obs, info
