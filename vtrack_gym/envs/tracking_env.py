"""``TrackingEnv``: the single Gymnasium env behind every registered id.

Scenario: a registered id or name (``envs.scenarios.SCENARIOS``) or a ``Scenario`` (its vehicle and control period
are the config's defaults; ``vehicle=`` and ``control_period_s=`` replace them); ``track=`` (a track file: a CSV
of points, an OpenDRIVE, Lanelet2, CommonRoad or GPX map; a ``tracks.Path`` or a built-in name),
``speed_profile=`` (a tracks speed profile, a speed in m/s or ``"file"``) and ``half_width_m=`` (a constant road
half width [m]) replace the scenario's; ``closed=`` (True/False, default detected), ``smoothing_m=`` (the fit's
RMS deviation from a file's points [m]), ``allow_self_crossing=True`` (a road over a bridge) and
``track_options=`` (``format``, ``route``, ``lane``, ``road_width_m``: see ``tracks.formats.TrackRead``) say how
a track file is read, e.g. ``gym.make("vtrack/Track-v0", track="my_track.csv")`` (default profile:
curvature-limited, 40 km/h, 0.7 g). With a speed profile the PD-FLC holds v_ref(s) at the car's station
(``target_speed`` in the observation and in
``info["target_speed_mps"]``, a preview of it at the end of the observation).

Observation: ``Box(float32)`` laid out by ``env.unwrapped.observation_layout`` (see ``envs.observation``).
Action: ``Box(-1, 1, (1,))``, the steering command as a fraction of the road-wheel limit (0.6 rad by
default); out-of-range values are clipped, NaN/inf or a wrong shape raise ``ValueError``. The PD-FLC speed
loop drives throttle and brake inside the env. ``control="steer_accel"`` / ``"steer_rate_accel"`` (``envs.control``)
make it ``Box(-1, 1, (2,))``: the steering command (or its rate) and a longitudinal demand through the documented
throttle/brake map, the PD-FLC off; the observation then ends with ``speed_error`` and ``time_error`` and the
reward has a speed term (``RewardConfig``).

Reward (per control step; weights in ``RewardConfig``):
``1 - w_ey |e_y|/(|e_y| + 0.1 m) - w_ephi |e_phi|/(|e_phi| + 0.05 rad) - w_effort a^2
- w_rate min(((a - a_prev)/0.1)^2, 1)`` (bounded: every step of driving earns >= 0.15 with the defaults) plus
``failure_penalty`` (-10) once on a failure termination. Terms in ``info["reward_*"]`` (0 at reset).

Info: the keys of ``envs.schema.INFO_KEYS`` at reset and at every step (numpy float64 scalars, ``fz_n`` (4,),
``acc_substeps_mps2`` (n_sub, 3), ``termination`` str, ``success`` bool: the scenario's verdict, False until the
step that ends the episode).

Termination (``info["termination"]``): ``completed`` (one lap of a closed course, or the end of an open
track), ``off_road`` (e_y beyond the road's left half width, or -e_y beyond its right one, at the car's
station), ``spin_out`` (|e_phi| > 90 deg, or above 3 m/s both the CG's and the rear axle's sideslip beyond
0.3 rad: rolling round a 6 m radius the CG alone has atan(a2/R) = 0.31 rad without any sliding), ``wheel_lift``
(a wheel's F_z <= 0), ``invalid_state`` (non-finite physics; never expected). ``truncated`` only from the scenario's
time limit (``spec.max_episode_steps`` is the same limit).
"""

from __future__ import annotations

import math
import numbers
from typing import Any

import gymnasium as gym
import numpy as np

from vtrack_gym.envs.config import EnvConfig, ResetOptions, Scenario
from vtrack_gym.envs.control import action_space as control_action_space
from vtrack_gym.envs.latency import Clock, DecisionTimer, Latency
from vtrack_gym.envs.scenarios import resolve_scenario, with_protocol
from vtrack_gym.envs.schema import info_dict
from vtrack_gym.envs.sim import TERMINATION_NAMES, BatchSim
from vtrack_gym.vehicle import layout as L
from vtrack_gym.vehicle.params import DesignModel


def _as_float_array(action: Any) -> np.ndarray:
    """``action`` as a float64 array; ``ValueError`` naming the action for anything but real numbers.

    Accepted: Python and numpy real numbers (bool, int, float), and arrays / nested sequences of them. Refused:
    strings and bytes (even numeric ones such as ``"1_0"``), complex, datetime / timedelta values, masked arrays
    and other objects.
    """
    if isinstance(action, (str, bytes, bytearray, memoryview, np.ma.MaskedArray)):
        raise ValueError(f"action must be a number or an array of numbers in [-1, 1] (got {type(action).__name__} "
                         f"{action!r})")
    try:
        arr = np.asarray(action)
        if arr.dtype.kind == "O":  # e.g. Python ints beyond int64: every element must be a real number
            if not all(isinstance(v, numbers.Real) and not isinstance(v, np.ma.core.MaskedConstant)
                       for v in arr.reshape(-1)):
                raise TypeError
            return arr.astype(np.float64)
        if arr.dtype.kind not in "biuf":
            raise TypeError
        return arr.astype(np.float64, copy=False)
    except (TypeError, ValueError, OverflowError):
        if _is_complex(action):
            raise ValueError(f"action must be real numbers (got complex {action!r})") from None
        raise ValueError(f"action must be a number or an array of numbers in [-1, 1] (got {action!r})") from None


def _is_complex(action: Any) -> bool:
    """Whether ``action`` is complex (False for anything numpy cannot type, e.g. ragged lists)."""
    try:
        return bool(np.iscomplexobj(action))
    except (TypeError, ValueError):
        return False


def check_actions(action: Any, n: int, dim: int = 1) -> np.ndarray:
    """Validate and clip a batch of steering actions to shape (n,) float64 in [-1, 1]; with ``dim`` 2 (the
    longitudinal control modes) a batch of (steering, demand) pairs to shape (n, 2)."""
    if dim != 1:
        return _check_pairs(action, n, dim)
    a = _as_float_array(action)
    if a.size != n:
        raise ValueError(f"action must have {n} element(s) (shape ({n}, 1) or ({n},) for a batch, (1,) for one "
                         f"env), got shape {a.shape}")
    a = a.reshape(n)
    if not np.isfinite(a).all():
        raise ValueError(f"action must be finite (got {action!r}); NaN/inf steering commands are refused")
    return np.clip(a, -1.0, 1.0)


def _check_pairs(action: Any, n: int, dim: int) -> np.ndarray:
    """``check_actions`` of the longitudinal control modes: (n, dim) float64 in [-1, 1]."""
    a = _as_float_array(action)
    if a.size != n * dim or (a.ndim >= 1 and a.shape[-1] != dim):
        single = f", ({dim},) for one env" if n == 1 else ""
        raise ValueError(f"action must have {n * dim} elements (shape ({n}, {dim}) for a batch{single}: steering "
                         f"and longitudinal demand), got shape {a.shape}")
    a = a.reshape(n, dim)
    if not np.isfinite(a).all():
        raise ValueError(f"action must be finite (got {action!r}); NaN/inf commands are refused")
    return np.clip(a, -1.0, 1.0)


def check_action_pair(action: Any) -> tuple[float, float]:
    """Validate one env's action of a longitudinal control mode (steering or its rate, and the demand: shape
    (2,)) and clip both to [-1, 1]."""
    a = _check_pairs(action, 1, 2)
    return float(a[0, 0]), float(a[0, 1])


def check_action(action: Any) -> float:
    """Validate one env's steering action (one element) and clip it to [-1, 1]; returns a float."""
    if type(action) is np.ndarray and action.shape == (1,) and action.dtype.kind == "f":
        a = float(action[0])  # the usual case (a sample of the action space), exactly as the general path reads it
    else:
        arr = _as_float_array(action)
        if arr.size != 1:
            raise ValueError(f"action must have 1 element (shape (1,)), got shape {arr.shape}")
        a = float(arr.reshape(-1)[0])
    if not math.isfinite(a):
        raise ValueError(f"action must be finite (got {action!r}); NaN/inf steering commands are refused")
    return -1.0 if a < -1.0 else (1.0 if a > 1.0 else a)


def observation_space(config: EnvConfig) -> gym.spaces.Box:
    """The float32 observation box (raw SI units, generous physical bounds from the layout)."""
    low, high = config.layout.bounds()
    return gym.spaces.Box(low, high, dtype=np.float32)


ACTION_SPACE = gym.spaces.Box(-1.0, 1.0, shape=(1,), dtype=np.float32)


def scenario_config(scenario: Scenario, config: EnvConfig | None, overrides: dict[str, Any]) -> EnvConfig:
    """The env's config: ``config`` as given (it carries the car and the control period), else an ``EnvConfig``
    of ``overrides`` whose car and control period default to the scenario's vehicle and control period parts."""
    if config is not None:
        if overrides:
            raise ValueError("pass either config or keyword overrides, not both")
        return config
    defaults: dict[str, Any] = {"control_period_s": scenario.control_period_s}
    if scenario.vehicle is not None:
        defaults["vehicle"] = scenario.vehicle
    return EnvConfig(**{**defaults, **overrides})


class TrackingEnv(gym.Env):
    """One car tracking a path; see the module docstring for spaces, reward and termination."""

    metadata = {"render_modes": ["rgb_array", "rgb_array_list", "human"], "render_fps": 25}  # noqa: RUF012

    def __init__(self, scenario: str | Scenario = "LateralTracking-v0", config: EnvConfig | None = None,
                 render_mode: str | None = None, render_fps: int = 25, render_view: str = "follow",
                 track: Any = None, speed_profile: Any = None, half_width_m: float | None = None,
                 closed: bool | None = None, smoothing_m: float | None = None, allow_self_crossing: bool | None = None,
                 track_options: dict[str, Any] | None = None, entry_speed_kmh: float | None = None,
                 reference: str | None = None, track_limits: str | None = None,
                 latency: str | float | None = None, latency_s: float | None = None,
                 latency_clock: Clock | None = None, **config_overrides: Any) -> None:
        scenario = resolve_scenario(scenario, track, speed_profile, half_width_m, closed, smoothing_m,
                                    {"allow_self_crossing": allow_self_crossing, "track_options": track_options})
        config = scenario_config(scenario, config, config_overrides)
        scenario = with_protocol(scenario, config.vehicle, entry_speed_kmh, reference, track_limits)
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']} (got {render_mode!r})")
        self.scenario = scenario
        self.config = config
        self.render_mode = render_mode
        self.observation_layout = config.layout
        self.control_period_s = config.control_period_s
        self.design_model = DesignModel.from_vehicle(config.vehicle)
        self.observation_space = observation_space(config)
        self.control = config.control
        """What the action drives (``envs.control``: steer, steer_accel or steer_rate_accel)."""
        self.action_space = ACTION_SPACE if config.control == "steer" else control_action_space(config.control)
        self.metadata = {**self.metadata, "render_fps": render_fps}
        self._sim = BatchSim(scenario, config, 1)
        self.scenario = scenario = self._sim.scenario  # with its time limit resolved
        self._steering_ratio = config.vehicle.steering.steering_ratio
        self._renderer = None
        from vtrack_gym.envs.render import EnvRenderer, RenderConfig  # light: Pillow is imported on first draw

        render_config = RenderConfig(fps=render_fps, view=render_view)  # validates both
        if render_mode is not None:
            self._renderer = EnvRenderer(render_mode, render_config, config.vehicle.chassis,
                                         config.control_period_s, scenario.name)
        self._needs_reset = True
        self.latency = self._default_latency = Latency.parse(latency, latency_s)
        """This episode's compute latency (``envs.latency``; make kwargs, or the reset options of the same names)."""
        self._timer = DecisionTimer(latency_clock)
        self._bind_rows()

    def _bind_rows(self) -> None:
        """Views of car 0's rows that ``step`` reads (the sim's arrays are modified in place, never rebound)."""
        sim = self._sim
        self._obs_row = sim.obs[0]
        self._sig_row = sim.sig[0]
        self._fz_row = sim.outputs[0, -1, L.O_FZFL:L.O_FZRR + 1]
        self._acc_rows = sim.outputs[0, :, L.O_AX:L.O_AZ + 1]

    def __setstate__(self, state: dict) -> None:
        """Unpickled (or deep-copied) with car 0's row views bound again, to the restored sim's own arrays."""
        self.__dict__.update(state)
        self._bind_rows()

    @property
    def paths(self) -> tuple:
        """The track(s) this env drives on."""
        return self._sim.paths

    @property
    def speed_tables(self) -> tuple:
        """The reference speed v_ref(s) on each track (``tracks.SpeedTable``), as the speed loop follows it: a
        profile with a ``throttle_authority`` bound to this env's car and speed loop."""
        return self._sim.tracks.speed_tables

    @property
    def current_path(self):
        """The path of the current episode."""
        return self._sim.paths[self._sim.veh_track[0]]

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        latency = Latency()
        if isinstance(options, dict) and ("latency" in options or "latency_s" in options):
            options = dict(options)
            latency = Latency.parse(options.pop("latency", None), options.pop("latency_s", None))
        opts = ResetOptions.from_dict(options)
        self.latency = latency if latency.on else self._default_latency
        self._sim.rngs[0] = self.np_random
        self._sim.reset_car(0, opts)
        self._sim.observe_after_reset(np.zeros(1, dtype=np.int64))
        self._needs_reset = False
        info = self._info(terminated=False)
        if self._renderer is not None:
            self._renderer.on_reset(self.current_path, self._sim)
        self._timer.handed_out()
        return self._obs_row.copy(), info

    def step(self, action: Any):
        if self._needs_reset:
            raise RuntimeError("call reset() before step() (and after an episode ends)")
        demand = None
        if self.control == "steer":
            action = check_action(action)
        else:
            action, demand = check_action_pair(action)
        spent = None
        if self.latency.on:
            spent = self.latency.seconds if self.latency.mode == "fixed" else self._timer.elapsed()
        reward, code, trunc = self._sim.step_one(action, spent, demand)
        term = code != 0
        self._needs_reset = term or trunc
        info = self._info(terminated=term)
        if self._renderer is not None:
            self._renderer.on_step(self.current_path, self._sim)
        if spent is not None:
            self._timer.handed_out()
        return self._obs_row.copy(), reward, term, trunc, info

    def charge_compute(self, seconds: float) -> None:
        """Charge ``seconds`` [s] as the next decision's compute (``latency="measured"``): a harness that timed
        the policy call itself passes that time instead of the env's own clock."""
        self._timer.charge(seconds)

    def latency_stats(self) -> dict[str, Any]:
        """The episode so far under compute latency: ``latency`` (``off``, ``measured`` or the fixed budget [s]),
        ``decisions``, ``late_decisions`` (delay above the control period), ``late_share`` (0..1) and
        ``max_latency_s`` [s] (all 0 when latency is off)."""
        return {"latency": self.latency.label, **self._sim.latency.stats(0)}

    def _info(self, terminated: bool) -> dict[str, Any]:
        """Every ``envs.schema.INFO_KEYS`` entry of the car (numpy scalars and arrays), cheap enough per step."""
        sim = self._sim
        cost, margin = sim.safety(0)
        return info_dict(int(sim.steps[0]) * self.control_period_s, self._sig_row, self._fz_row.copy(),
                         self._acc_rows.copy(), TERMINATION_NAMES[int(sim.term[0])] if terminated else "",
                         terminated and bool(sim.success()[0]), cost, margin)

    def success_metrics(self) -> dict[str, float]:
        """The scenario's success criterion's leaderboard figures of the current (or last) episode, e.g.
        ``cones_hit`` on a course with cone gates (``envs.criteria``)."""
        return self._sim.success_metrics(0)

    def render(self):
        """rgb_array: the current frame; rgb_array_list: the frames taken at ``render_fps`` since the last call;
        human: show the current frame (``envs.render.EnvRenderer``)."""
        if self._renderer is None:
            gym.logger.warn("render() called without a render_mode; pass render_mode='rgb_array', "
                            "'rgb_array_list' or 'human'")
            return None
        return self._renderer.render(self.current_path, self._sim)

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
